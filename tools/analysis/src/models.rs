//! Which fitted models a command uses: the study's defaults (section 4's seven isotropic
//! models; section 5's anisotropic Ward, Ashikhmin-Shirley and Poulin-Fournier for 4D data)
//! or a comma-separated list of labels, checked against the fitter's models.

pub use lobe_materials::fit::ANISOTROPIC_DEFAULT;
use lobe_materials::fit::{ISOTROPIC_DEFAULT, ModelSpec};
use lobe_renderer::Error;

/// The default labels for isotropic or anisotropic data.
pub fn defaults(anisotropic: bool) -> &'static [&'static str] {
    if anisotropic {
        ANISOTROPIC_DEFAULT
    } else {
        ISOTROPIC_DEFAULT
    }
}

/// The specs of the comma-separated `models` (an error names an unknown one and lists the
/// known ones), or the study's defaults for isotropic or anisotropic data.
pub fn choose<'a>(
    specs: &'a [ModelSpec],
    models: Option<&str>,
    anisotropic: bool,
) -> Result<Vec<&'a ModelSpec>, Error> {
    match models {
        None => {
            let default = defaults(anisotropic);
            Ok(specs
                .iter()
                .filter(|s| default.contains(&s.label))
                .collect())
        }
        Some(list) => list
            .split(',')
            .map(|l| {
                specs.iter().find(|s| s.label == l.trim()).ok_or_else(|| {
                    Error::Other(format!(
                        "--models: unknown model \"{}\"; expected one of: {}",
                        l.trim(),
                        specs.iter().map(|s| s.label).collect::<Vec<_>>().join(", ")
                    ))
                })
            })
            .collect(),
    }
}

/// The spec of one model label.
pub fn spec(specs: &[ModelSpec], label: &str) -> Result<ModelSpec, Error> {
    Ok(choose(specs, Some(label), false)?.remove(0).clone())
}
