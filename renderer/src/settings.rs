//! Render settings: what one render of a scene does (the scene file's `film`, `sampler` and
//! `integrator`, docs/scene-format.md), apart from the world it renders (shapes, lights,
//! materials: [`crate::scene::World`]); a [`crate::scene::Scene`] holds both, with its
//! camera. Callers override them after loading (the CLI's `--spp`, `--seed`, film size);
//! the render loop reads them and the scene loader fills them, so neither depends on the
//! other through them.

use crate::sampler::Scramble;

/// The film, the sampler and the integrator of a render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u64,
    /// How the sampler randomizes its points (`sampler.scramble`).
    pub scramble: Scramble,
    /// Exposure (stops) for the PNG output.
    pub exposure: f32,
    pub integrator: Integrator,
}

/// Which light transport algorithm renders the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Integrator {
    /// `max_depth`: longest path in vertices, Mitsuba's meaning: 1 shows only directly
    /// visible emitters, 2 adds direct illumination; `None` is unbounded.
    /// Russian roulette starts at path depth `rr_depth`.
    Path {
        max_depth: Option<u32>,
        rr_depth: u32,
    },
    /// Direct illumination with `emitter_samples` light samples and `bsdf_samples` BSDF
    /// samples per hit, combined with the power heuristic (Mitsuba's `direct`).
    Direct {
        emitter_samples: u32,
        bsdf_samples: u32,
    },
}
