//! The world a scene renders: its shapes (their geometry and BVH, each shape's material
//! and area light) and its lights. It is what the integrators read; the film, sampler and
//! integrator settings ([`crate::settings::RenderSettings`]) and the camera sit beside it
//! in [`super::Scene`].

use crate::geometry::Geometry;
use crate::lights::Light;
use lobe_materials::Bsdf;
use std::sync::Arc;

/// The shapes and lights of a scene.
pub struct World {
    pub geometry: Geometry,
    /// Per shape, its material and area light (indexed by [`crate::geometry::Interaction::shape`]).
    pub shapes: Vec<ShapeInfo>,
    pub lights: Vec<Light>,
    /// Indices of environment-like lights (env maps, constant), evaluated on escape.
    pub infinite_lights: Vec<u32>,
}

impl World {
    /// Probability of choosing each light (uniform selection, Mitsuba's), 0 without lights.
    pub fn light_select_pdf(&self) -> f32 {
        if self.lights.is_empty() {
            0.0
        } else {
            1.0 / self.lights.len() as f32
        }
    }
}

/// A shape's material and, if it emits, its light.
#[derive(Clone, Debug)]
pub struct ShapeInfo {
    pub material: Arc<dyn Bsdf>,
    /// The number of this shape's material among the scene's distinct materials (shapes
    /// sharing one material, the same `Arc`, share the number; numbered in order of first
    /// appearance): the key the wavefront groups hits by.
    pub material_group: u32,
    /// Index into [`World::lights`] of this shape's area light.
    pub light: Option<u32>,
}
