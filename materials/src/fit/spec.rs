//! The models as the fitter sees them (Ngan et al. 2005, sections 3.1-3.3, 4.2-4.4 and 5),
//! derived from the models' own declarations ([`crate::schema::LobeModel`], in their files
//! under `analytic/`): each fit variant of a model becomes a [`ModelSpec`] whose free
//! parameters are the schema parameters with a fit range (those whose `when` setting
//! matches the variant's settings), in schema order.

use crate::schema::{Contains, FitGroup, LobeModel, ParamKind};
use serde_json::{Value, json};

/// One optimized lobe parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct FitParam {
    pub name: &'static str,
    pub lo: f64,
    pub hi: f64,
    /// Optimize its logarithm (scale parameters).
    pub log: bool,
    /// Starting values of the multi-start grid.
    pub starts: &'static [f64],
    /// Also sets these parameters to the same value (e.g. Lafortune's cx = cy).
    pub tied: &'static [&'static str],
}

/// A model as fitted: the registry model, its fixed settings, its free parameters, and
/// how many lobes share the shape family (each lobe gets its own parameters and colour).
#[derive(Clone, Debug, PartialEq)]
pub struct ModelSpec {
    pub label: &'static str,
    pub model: &'static str,
    pub settings: Value,
    pub params: Vec<FitParam>,
    pub lobes: usize,
    /// The study's set the variant belongs to (an `Anisotropic` model fitted to isotropic
    /// data is warned about).
    pub group: FitGroup,
    /// The simpler variant it contains, whose optimum its fit starts from.
    pub contains: Option<Contains>,
}

/// The fit specs of one declared model, one per fit variant, in declaration order.
pub fn model_specs(m: &LobeModel) -> Vec<ModelSpec> {
    m.fits
        .iter()
        .map(|v| {
            let mut settings = json!({});
            for (k, val) in v.settings {
                settings[*k] = json!(val);
            }
            // A setting the variant does not fix keeps the schema's default.
            let setting = |name: &str| {
                v.settings
                    .iter()
                    .find(|(k, _)| *k == name)
                    .map(|(_, val)| *val)
                    .or_else(|| {
                        m.schema
                            .params
                            .iter()
                            .find(|p| p.name == name)
                            .and_then(|p| match (p.kind, p.default) {
                                (ParamKind::Choice(_), crate::schema::DefaultValue::Choice(c)) => {
                                    Some(c)
                                }
                                _ => None,
                            })
                    })
            };
            let params = m
                .schema
                .params
                .iter()
                .filter_map(|p| {
                    let f = p.fit?;
                    if let Some((name, value)) = f.when
                        && setting(name) != Some(value)
                    {
                        return None;
                    }
                    Some(FitParam {
                        name: p.name,
                        lo: f.lo,
                        hi: f.hi,
                        log: f.log,
                        starts: f.starts,
                        tied: f.tied,
                    })
                })
                .collect();
            ModelSpec {
                label: v.label,
                model: m.schema.name,
                settings,
                params,
                lobes: v.lobes,
                group: v.group,
                contains: v.contains,
            }
        })
        .collect()
}

/// The fit specs of every analytic model lobe ships with ([`crate::analytic::MODELS`]):
/// the study's isotropic models (section 4), their variations (sections 4.3, 4.4), two
/// lobes (section 4.2), then the anisotropic models (section 5).
pub fn builtin_specs() -> Vec<ModelSpec> {
    let mut all: Vec<(FitGroup, ModelSpec)> = Vec::new();
    for m in crate::analytic::MODELS {
        for (v, s) in m.fits.iter().zip(model_specs(m)) {
            all.push((v.group, s));
        }
    }
    // Stable: within a group, in the order of the models' list and of their variants.
    all.sort_by_key(|(g, _)| *g);
    all.into_iter().map(|(_, s)| s).collect()
}

/// How many builtin fit variants belong to `group`.
const fn count_in(group: FitGroup) -> usize {
    let models = crate::analytic::MODELS;
    let (mut i, mut n) = (0, 0);
    while i < models.len() {
        let mut j = 0;
        while j < models[i].fits.len() {
            if models[i].fits[j].group as u8 == group as u8 {
                n += 1;
            }
            j += 1;
        }
        i += 1;
    }
    n
}

/// The labels of the builtin fit variants of `group`, in [`builtin_specs`] order.
const fn labels_in<const N: usize>(group: FitGroup) -> [&'static str; N] {
    let models = crate::analytic::MODELS;
    let mut out = [""; N];
    let (mut i, mut n) = (0, 0);
    while i < models.len() {
        let mut j = 0;
        while j < models[i].fits.len() {
            if models[i].fits[j].group as u8 == group as u8 {
                out[n] = models[i].fits[j].label;
                n += 1;
            }
            j += 1;
        }
        i += 1;
    }
    out
}

const ISOTROPIC_COUNT: usize = count_in(FitGroup::Isotropic);
const ANISOTROPIC_COUNT: usize = count_in(FitGroup::Anisotropic);

/// The labels of the models fitted to isotropic data by default (section 4).
pub const ISOTROPIC_DEFAULT: &[&str] = &labels_in::<ISOTROPIC_COUNT>(FitGroup::Isotropic);

/// The labels of the models fitted to anisotropic (4D) data by default (section 5).
pub const ANISOTROPIC_DEFAULT: &[&str] = &labels_in::<ANISOTROPIC_COUNT>(FitGroup::Anisotropic);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::registry::Registry;

    /// The material of `spec` with its free parameters at `values` (tied ones copied), a
    /// diffuse and a specular colour.
    fn material(spec: &ModelSpec, values: &[f64]) -> Value {
        let mut d = spec.settings.clone();
        d["type"] = json!(spec.model);
        d["diffuse"] = json!(0.1);
        d["specular"] = json!(0.5);
        for (p, v) in spec.params.iter().zip(values) {
            d[p.name] = json!(v);
            for t in p.tied {
                d[*t] = json!(v);
            }
        }
        d
    }

    /// Every fit variant's box is one the optimizer can search and the model accepts: lo <
    /// hi (lo > 0 where searched in log space), the starting points inside, every corner
    /// and every start building a material that is finite and non-negative.
    #[test]
    fn fit_boxes_are_searchable_and_accepted_by_their_models() {
        let reg = Registry::builtin();
        let specs = builtin_specs();
        let dirs = [(0.0f32, 0.0f32), (30.0, 0.0), (60.0, 180.0), (85.0, 90.0)].map(|(t, p)| {
            let (t, p) = (t.to_radians(), p.to_radians());
            glam::Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
        });
        let mut built = 0;
        for spec in &specs {
            assert!(!spec.params.is_empty(), "{}: nothing to fit", spec.label);
            for p in &spec.params {
                assert!(p.lo.is_finite() && p.hi.is_finite() && p.lo < p.hi, "{p:?}");
                assert!(!p.log || p.lo > 0.0, "{}: log range from {}", p.name, p.lo);
                assert!(!p.starts.is_empty(), "{}: no start", p.name);
                for s in p.starts {
                    assert!((p.lo..=p.hi).contains(s), "{}: start {s} outside", p.name);
                }
            }
            // Corners (lo or hi for each parameter) and the start grid's diagonal.
            let n = spec.params.len();
            let corners = (0..1usize << n).map(|bits| {
                (0..n)
                    .map(|i| {
                        let p = &spec.params[i];
                        if bits >> i & 1 == 1 { p.hi } else { p.lo }
                    })
                    .collect::<Vec<_>>()
            });
            let starts = (0..3).map(|k| {
                spec.params
                    .iter()
                    .map(|p| p.starts[k.min(p.starts.len() - 1)])
                    .collect::<Vec<_>>()
            });
            for values in corners.chain(starts) {
                let desc = material(spec, &values);
                let m = reg
                    .create(&desc, "spec")
                    .unwrap_or_else(|e| panic!("{}: {desc} refused: {e}", spec.label));
                for wo in dirs {
                    for wi in dirs {
                        let f = m.eval(wo, wi);
                        assert!(f.is_finite() && f.min_component() >= 0.0, "{desc}: {f:?}");
                    }
                }
                built += 1;
            }
        }
        assert!(built > 100, "{built} materials built");
    }

    /// The variants' labels are unique; a variant that contains a simpler one names an
    /// existing variant and parameters of both; the study's defaults are its seven
    /// isotropic models (section 4) and three anisotropic ones (section 5).
    #[test]
    fn variants_name_what_they_contain_and_the_defaults_are_the_studys() {
        let specs = builtin_specs();
        let find = |label: &str| specs.iter().find(|s| s.label == label);
        for (k, s) in specs.iter().enumerate() {
            assert!(
                specs[..k].iter().all(|o| o.label != s.label),
                "{} twice",
                s.label
            );
            if let Some(c) = &s.contains {
                let inner = find(c.label).unwrap_or_else(|| panic!("{}: {}", s.label, c.label));
                for (mine, theirs) in c.params {
                    assert!(
                        s.params.iter().any(|p| p.name == *mine),
                        "{}: {mine}",
                        s.label
                    );
                    assert!(
                        inner.params.iter().any(|p| p.name == *theirs),
                        "{}",
                        c.label
                    );
                }
            }
        }
        let mut iso = ISOTROPIC_DEFAULT.to_vec();
        iso.sort_unstable();
        assert_eq!(
            iso,
            [
                "ashikhmin-shirley",
                "blinn-phong",
                "cook-torrance",
                "he",
                "lafortune",
                "ward",
                "ward-duer"
            ]
        );
        let mut aniso = ANISOTROPIC_DEFAULT.to_vec();
        aniso.sort_unstable();
        assert_eq!(
            aniso,
            [
                "ashikhmin-shirley-anisotropic",
                "poulin-fournier",
                "ward-anisotropic"
            ]
        );
        for label in ISOTROPIC_DEFAULT.iter().chain(ANISOTROPIC_DEFAULT) {
            let s = find(label).unwrap();
            assert_eq!(s.lobes, 1, "{label}");
        }
    }
}
