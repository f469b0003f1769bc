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

    /// The fit ranges and starting points the fit reports of lobe are made with: the
    /// specs derived from the models' declarations must equal them exactly, in order
    /// (widened where Ngan's published fits lie outside: Lafortune's cz down to 1e-12 in
    /// log space, He's sigma0 and tau, Ashikhmin-Shirley's exponents below 1).
    #[test]
    fn derived_specs_equal_the_hand_written_table() {
        const fn p(
            name: &'static str,
            lo: f64,
            hi: f64,
            log: bool,
            starts: &'static [f64],
        ) -> FitParam {
            FitParam {
                name,
                lo,
                hi,
                log,
                starts,
                tied: &[],
            }
        }

        fn lafortune_params() -> Vec<FitParam> {
            vec![
                FitParam {
                    name: "cx",
                    lo: -1.0,
                    hi: 1.0,
                    log: false,
                    starts: &[-0.6],
                    tied: &["cy"],
                },
                p("cz", 1e-12, 1.0, true, &[0.6]),
                p("n", 1.0, 1e5, true, &[10.0, 100.0, 1000.0]),
            ]
        }

        /// `builtin_specs` as it was written out by hand before the models declared their fits.
        fn hand_written_specs() -> Vec<ModelSpec> {
            let ct = |label, dist: &str, fresnel: &str, lobes| {
                let mut params = vec![p("m", 1e-3, 1.0, true, &[0.03, 0.1, 0.3])];
                match fresnel {
                    "schlick" => params.push(p("f0", 0.0, 1.0, false, &[0.05, 0.5])),
                    "dielectric" => params.push(p("eta", 1.001, 20.0, true, &[1.5, 4.0])),
                    _ => {}
                }
                ModelSpec {
                    label,
                    model: "cook-torrance",
                    settings: json!({"distribution": dist, "fresnel": fresnel}),
                    params,
                    lobes,
                    group: if lobes == 2 {
                        FitGroup::TwoLobes
                    } else if label == "cook-torrance" {
                        FitGroup::Isotropic
                    } else {
                        FitGroup::Variant
                    },
                    contains: None,
                }
            };
            vec![
                ModelSpec {
                    label: "ward",
                    model: "ward",
                    settings: json!({}),
                    params: vec![p("alpha", 1e-3, 1.0, true, &[0.03, 0.1, 0.3])],
                    lobes: 1,
                    group: FitGroup::Isotropic,
                    contains: None,
                },
                ModelSpec {
                    label: "ward-duer",
                    model: "ward-duer",
                    settings: json!({}),
                    params: vec![p("alpha", 1e-3, 1.0, true, &[0.03, 0.1, 0.3])],
                    lobes: 1,
                    group: FitGroup::Isotropic,
                    contains: None,
                },
                ModelSpec {
                    label: "blinn-phong",
                    model: "blinn-phong",
                    settings: json!({}),
                    params: vec![p("n", 1.0, 1e6, true, &[10.0, 100.0, 1000.0])],
                    lobes: 1,
                    group: FitGroup::Isotropic,
                    contains: None,
                },
                ct("cook-torrance", "beckmann", "schlick", 1),
                ModelSpec {
                    label: "lafortune",
                    model: "lafortune",
                    settings: json!({"normalization": "ngan"}),
                    params: lafortune_params(),
                    lobes: 1,
                    group: FitGroup::Isotropic,
                    contains: None,
                },
                ModelSpec {
                    label: "ashikhmin-shirley",
                    model: "ashikhmin-shirley",
                    settings: json!({}),
                    params: vec![
                        p("n", 0.1, 1e6, true, &[10.0, 100.0, 1000.0]),
                        p("f0", 0.0, 1.0, false, &[0.05, 0.5]),
                    ],
                    lobes: 1,
                    group: FitGroup::Isotropic,
                    contains: None,
                },
                ModelSpec {
                    label: "he",
                    model: "he",
                    settings: json!({}),
                    params: vec![
                        p("sigma0", 1e-3, 10.0, true, &[0.1, 1.0]),
                        p("tau", 0.03, 200.0, true, &[3.0, 30.0]),
                        p("eta", 1.001, 20.0, true, &[1.5]),
                    ],
                    lobes: 1,
                    group: FitGroup::Isotropic,
                    contains: None,
                },
                ct("cook-torrance-gaussian", "gaussian", "schlick", 1),
                ct("cook-torrance-cosine-power", "cosine-power", "schlick", 1),
                ct("cook-torrance-no-fresnel", "beckmann", "none", 1),
                ct("cook-torrance-dielectric", "beckmann", "dielectric", 1),
                ModelSpec {
                    contains: Some(Contains {
                        label: "cook-torrance",
                        params: &[("m", "m"), ("f0", "f0")],
                    }),
                    ..ct("cook-torrance-2", "beckmann", "schlick", 2)
                },
                ModelSpec {
                    label: "lafortune-2",
                    model: "lafortune",
                    settings: json!({"normalization": "ngan"}),
                    params: lafortune_params(),
                    lobes: 2,
                    group: FitGroup::TwoLobes,
                    contains: Some(Contains {
                        label: "lafortune",
                        params: &[("cx", "cx"), ("cz", "cz"), ("n", "n")],
                    }),
                },
                // Section 5: anisotropic models, for 4D (binned) data.
                ModelSpec {
                    label: "ward-anisotropic",
                    model: "ward-anisotropic",
                    settings: json!({}),
                    params: vec![
                        p("alpha_x", 1e-3, 1.0, true, &[0.03, 0.2]),
                        p("alpha_y", 1e-3, 1.0, true, &[0.03, 0.2]),
                    ],
                    lobes: 1,
                    group: FitGroup::Anisotropic,
                    contains: Some(Contains {
                        label: "ward",
                        params: &[("alpha_x", "alpha"), ("alpha_y", "alpha")],
                    }),
                },
                ModelSpec {
                    label: "ashikhmin-shirley-anisotropic",
                    model: "ashikhmin-shirley-anisotropic",
                    settings: json!({}),
                    params: vec![
                        p("nu", 0.1, 1e6, true, &[10.0, 1000.0]),
                        p("nv", 0.1, 1e6, true, &[10.0, 1000.0]),
                        p("f0", 0.0, 1.0, false, &[0.1]),
                    ],
                    lobes: 1,
                    group: FitGroup::Anisotropic,
                    contains: Some(Contains {
                        label: "ashikhmin-shirley",
                        params: &[("nu", "n"), ("nv", "n"), ("f0", "f0")],
                    }),
                },
                ModelSpec {
                    label: "poulin-fournier",
                    model: "poulin-fournier",
                    settings: json!({}),
                    params: vec![
                        p("n", 1.0, 1e5, true, &[30.0, 1000.0]),
                        p("d", 0.0, 5.0, false, &[0.2, 1.0]),
                        p("h", 0.0, 1.0, false, &[0.5]),
                    ],
                    lobes: 1,
                    group: FitGroup::Anisotropic,
                    contains: None,
                },
            ]
        }

        let derived = builtin_specs();
        let expected = hand_written_specs();
        assert_eq!(derived.len(), expected.len());
        for (d, e) in derived.iter().zip(&expected) {
            assert_eq!(d, e);
        }
        assert_eq!(
            ISOTROPIC_DEFAULT,
            [
                "ward",
                "ward-duer",
                "blinn-phong",
                "cook-torrance",
                "lafortune",
                "ashikhmin-shirley",
                "he",
            ]
        );
        assert_eq!(
            ANISOTROPIC_DEFAULT,
            [
                "ward-anisotropic",
                "ashikhmin-shirley-anisotropic",
                "poulin-fournier",
            ]
        );
    }
}
