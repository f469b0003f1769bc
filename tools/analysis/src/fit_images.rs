//! The environment maps of the `image` fitting metric ([`lobe_materials::fit::image`]): the
//! renderer's environment maps (Mitsuba's `envmap` conventions, the scene loader's
//! importance sampling) seen through the fitting library's [`Environment`], the default
//! fitting maps, and the sphere renders of a measured material a fit is compared with.

use lobe_materials::Bsdf;
use lobe_materials::fit::image::{Environment, ImageSettings, SphereImages};
use lobe_renderer::Error;
use lobe_renderer::image_io::RgbImage;
use lobe_renderer::lights::envmap::{EnvMap, load_rgb_image};
use lobe_renderer::scene::builtin_images::{studio_environment, sunset_environment};
use std::path::Path;

/// The maps the image metric fits under by default: the built-in studio and the embedded
/// sunset.
pub const DEFAULT_FIT_ENVS: [&str; 2] = ["builtin:studio", "builtin:sunset"];

/// The pixels of an environment map named as a scene names it: `builtin:studio`,
/// `builtin:sunset` (the embedded map) or an image file (.exr or .hdr).
pub fn environment_image(spec: &str) -> Result<RgbImage, Error> {
    match spec {
        "builtin:studio" => Ok(studio_environment(512, 256)),
        "builtin:sunset" => Ok(sunset_environment()),
        other if other.starts_with("builtin:") => Err(Error::Other(format!(
            "--env: unknown built-in map \"{other}\"; expected builtin:studio, builtin:sunset or an image file"
        ))),
        file => {
            let p = Path::new(file);
            if !p.exists() {
                return Err(Error::file(
                    file,
                    "does not exist; expected an environment map (.exr or .hdr)",
                ));
            }
            load_rgb_image(p)
        }
    }
}

/// A renderer environment map as the image metric samples it.
pub struct FitEnvironment(pub EnvMap);

impl FitEnvironment {
    /// The map of `spec` ([`environment_image`]), unscaled and unrotated, as a scene's
    /// `envmap` light without options.
    pub fn load(spec: &str) -> Result<Self, Error> {
        let img = environment_image(spec)?;
        Ok(Self(EnvMap::new(&img, 1.0, glam::Mat3::IDENTITY)))
    }
}

impl Environment for FitEnvironment {
    fn sample(&self, u: [f64; 2]) -> Option<(glam::Vec3, [f64; 3], f64)> {
        let u = glam::Vec2::new(
            (u[0] as f32).min(1.0 - f32::EPSILON),
            (u[1] as f32).min(1.0 - f32::EPSILON),
        );
        let (d, l, pdf) = self.0.sample(u)?;
        (pdf > 0.0).then_some((d, [l.r as f64, l.g as f64, l.b as f64], pdf as f64))
    }

    fn eval_pdf(&self, d: glam::Vec3) -> ([f64; 3], f64) {
        let (l, pdf) = self.0.eval_pdf(d);
        ([l.r as f64, l.g as f64, l.b as f64], pdf as f64)
    }
}

/// The image metric's renders under the maps `envs` (or [`DEFAULT_FIT_ENVS`] when empty),
/// with the render of `measured` as the reference.
pub fn fitting_images(
    envs: &[String],
    measured: &dyn Bsdf,
    settings: ImageSettings,
) -> Result<SphereImages, Error> {
    let specs: Vec<String> = if envs.is_empty() {
        DEFAULT_FIT_ENVS.iter().map(|s| s.to_string()).collect()
    } else {
        envs.to_vec()
    };
    let maps: Vec<FitEnvironment> = specs
        .iter()
        .map(|s| FitEnvironment::load(s))
        .collect::<Result<_, _>>()?;
    let refs: Vec<&dyn Environment> = maps.iter().map(|m| m as &dyn Environment).collect();
    let images = SphereImages::new(&refs, settings);
    Ok(images.with_reference(&|wi, wo| {
        let v = measured.eval(wo, wi);
        [v.r as f64, v.g as f64, v.b as f64]
    }))
}
