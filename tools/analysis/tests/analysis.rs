//! The library functions of lobe-analysis, called directly: model choice and selection,
//! cost measurement, fitting into a report, report reading and merging, the trade-off
//! study on a tiny configuration, the stability sweep and the figures.

use lobe_analysis::cost::{Cost, measure};
use lobe_analysis::plot::{self, Figure, RGBColor};
use lobe_analysis::selection::{cheapest_within, select};
use lobe_analysis::{figures, fitting, models, reports, stability, tradeoff};
use lobe_materials::fit::dataset::Dataset;
use lobe_materials::fit::report::{self, FitReport, ModelFit};
use lobe_materials::fit::{FitResult, builtin_specs};
use lobe_materials::measured::binned::{Axis, Binned};
use lobe_materials::registry::Registry;
use serde_json::json;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The built-in models, built once for every test.
static REGISTRY: std::sync::LazyLock<Registry> = std::sync::LazyLock::new(Registry::builtin);

fn material(desc: serde_json::Value) -> Arc<dyn lobe_materials::Bsdf> {
    Registry::builtin().create(&desc, "m").unwrap()
}

fn ward() -> serde_json::Value {
    json!({"type": "ward", "diffuse": [0.2, 0.15, 0.1], "specular": 0.3, "alpha": 0.15})
}

fn cost(total: f64) -> Cost {
    Cost {
        eval_ns: total / 2.0,
        sample_ns: total / 2.0,
    }
}

#[test]
fn selection_picks_the_cheapest_model_within_the_tolerance() {
    let c = [
        ("best", 1.0, cost(100.0)),
        ("close-cheap", 1.05, cost(20.0)),
        ("far-cheapest", 1.5, cost(5.0)),
    ];
    assert_eq!(cheapest_within(&c, 0.1), ("close-cheap", 1.0));
    // A tighter tolerance leaves only the best.
    assert_eq!(cheapest_within(&c, 0.01), ("best", 1.0));
    // A looser one admits the cheapest of all.
    assert_eq!(cheapest_within(&c, 0.6), ("far-cheapest", 1.0));
}

#[test]
fn selection_ties_go_to_the_first_model() {
    let c = [
        ("first", 1.0, cost(10.0)),
        ("second", 1.0, cost(10.0)),
        ("third", 1.02, cost(10.0)),
    ];
    assert_eq!(cheapest_within(&c, 0.1).0, "first");
    let (model, best) = cheapest_within(&[], 0.1);
    assert_eq!(model, "");
    assert!(best.is_infinite());
}

fn result(label: &str, desc: serde_json::Value, error: f64) -> FitResult {
    FitResult {
        label: label.into(),
        material: desc,
        error,
        error_normalized: error * 2.0,
        starts: 1,
        starts_agreeing: 1,
        evaluations: 1,
        seconds: 0.0,
        ..Default::default()
    }
}

#[test]
fn selection_measures_every_model_and_refuses_one_that_cannot_be_built() {
    let results = [
        result("ward", ward(), 0.01),
        result(
            "lambert",
            json!({"type": "lambert", "reflectance": 0.2}),
            0.5,
        ),
    ];
    let s = select(&REGISTRY, &results, 0.1).unwrap();
    // Lambert is far outside the tolerance, whatever its cost.
    assert_eq!(s.model, "ward");
    assert_eq!(s.best_error, 0.01);
    assert_eq!(s.costs.len(), 2);
    assert_eq!(s.costs["lambert"].error, 0.5);
    assert!(
        s.costs
            .values()
            .all(|c| c.eval_ns > 0.0 && c.sample_ns > 0.0)
    );
    let broken = [
        result("ward", ward(), 0.01),
        result("missing", json!({"type": "no-such-model"}), 0.01),
    ];
    let e = select(&REGISTRY, &broken, 0.1).unwrap_err().to_string();
    assert!(e.contains("missing") && e.contains("no-such-model"), "{e}");
}

#[test]
fn cost_is_a_positive_finite_time_per_call() {
    for desc in [ward(), json!({"type": "lambert", "reflectance": 0.5})] {
        let c = measure(material(desc.clone()).as_ref());
        for t in [c.eval_ns, c.sample_ns] {
            assert!(t.is_finite() && t > 0.0 && t < 1e6, "{desc}: {c:?}");
        }
        assert_eq!(c.total(), c.eval_ns + c.sample_ns);
    }
}

#[test]
fn models_are_chosen_by_label_or_by_the_data() {
    let specs = builtin_specs();
    let labels = |v: Vec<&lobe_materials::fit::ModelSpec>| -> Vec<&str> {
        v.iter().map(|s| s.label).collect()
    };
    let iso = labels(models::choose(&specs, None, false).unwrap());
    assert_eq!(iso.len(), 7);
    assert!(iso.contains(&"lafortune") && !iso.contains(&"poulin-fournier"));
    let aniso = labels(models::choose(&specs, None, true).unwrap());
    assert_eq!(aniso, models::ANISOTROPIC_DEFAULT);
    let listed = labels(models::choose(&specs, Some("he, ward"), false).unwrap());
    assert_eq!(listed, ["he", "ward"]);
    let e = models::choose(&specs, Some("ward,nope"), false)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("unknown model \"nope\"") && e.contains("cook-torrance"),
        "{e}"
    );
}

#[test]
fn fitting_a_material_gives_a_report_with_its_selection() {
    let m = material(ward());
    let data = Dataset::isotropic(&|wi, wo| Some(m.eval(wo, wi)), 6.0);
    let opts = fitting::FitOptions {
        models: Some("ward,blinn-phong".into()),
        resolution: 6.0,
        max_evals: 60,
        select: Some(0.1),
        ..Default::default()
    };
    let seen = std::sync::Mutex::new(Vec::new());
    let r = fitting::fit_material(&REGISTRY, "w", "material", &data, &opts, &|| false, &|f| {
        seen.lock().unwrap().push(f.label.clone())
    })
    .unwrap();
    assert_eq!(*seen.lock().unwrap(), ["ward", "blinn-phong"]);
    assert_eq!(r.material, "w");
    assert_eq!(r.samples, data.samples.len());
    // Ward fits Ward data almost exactly, far better than Blinn-Phong: it is selected.
    assert!(r.models["ward"].error < 0.1 * r.models["blinn-phong"].error);
    assert_eq!(r.selected.as_ref().unwrap().model, "ward");
    let stopped = fitting::fit_material(&REGISTRY, "w", "src", &data, &opts, &|| true, &|_| {});
    assert!(
        stopped
            .unwrap_err()
            .to_string()
            .contains("src: interrupted")
    );
}

/// A material's models are fitted in waves, a wave's models in parallel, a model after the
/// one it contains (listed here before it): every fit is the same bits as the model fitted
/// alone (the contained one then fitted for the purpose), at one thread and at two, and
/// progress sees each model once, a wave in the order given.
#[test]
fn models_fitted_in_parallel_waves_are_the_models_fitted_one_by_one() {
    let m = material(ward());
    let data = Dataset::isotropic(&|wi, wo| Some(m.eval(wo, wi)), 6.0);
    let opts = |models: &str| fitting::FitOptions {
        models: Some(models.into()),
        resolution: 6.0,
        max_evals: 30,
        select: None,
        ..Default::default()
    };
    // A fit with its timing taken out.
    let untimed = |f: &ModelFit| {
        let mut v = serde_json::to_value(f).unwrap();
        v["seconds"] = json!(0);
        v
    };
    let run = |models: &str, threads: usize| {
        let seen = std::sync::Mutex::new(Vec::new());
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let r = pool.install(|| {
            let on_model = |f: &FitResult| seen.lock().unwrap().push(f.label.clone());
            fitting::fit_material(
                &REGISTRY,
                "w",
                "m",
                &data,
                &opts(models),
                &|| false,
                &on_model,
            )
            .unwrap()
        });
        let fits: Vec<(String, serde_json::Value)> = (r.models.iter())
            .map(|(k, f)| (k.clone(), untimed(f)))
            .collect();
        (fits, seen.into_inner().unwrap())
    };
    let all = "cook-torrance-2,ward,cook-torrance";
    for threads in [1, 2] {
        let (fits, seen) = run(all, threads);
        assert_eq!(
            seen,
            ["ward", "cook-torrance", "cook-torrance-2"],
            "{threads} threads"
        );
        assert_eq!(fits.len(), 3);
        for (label, fit) in &fits {
            let (alone, _) = run(label, 1);
            assert_eq!(
                alone,
                [(label.clone(), fit.clone())],
                "{label}, {threads} threads"
            );
        }
        let two_lobes = &fits.iter().find(|f| f.0 == "cook-torrance-2").unwrap().1;
        assert_eq!(
            two_lobes["started_from"]["model"], "cook-torrance",
            "{two_lobes}"
        );
    }
}

/// On isotropic data an anisotropic model starts from the optimum of the isotropic model it
/// contains and is never worse than it, even on a budget too small for its own grid of
/// starts (from it, anisotropic Ashikhmin-Shirley ended 28 % worse than the isotropic
/// model); the report says the data is isotropic and which optimum it started from.
#[test]
fn an_anisotropic_fit_to_isotropic_data_is_never_worse_than_the_model_it_contains() {
    let he = material(
        json!({"type": "he", "diffuse": [0.1, 0.1, 0.1], "specular": 0.5,
                             "sigma0": 0.3, "tau": 4.0, "eta": 1.5}),
    );
    let data = Dataset::isotropic(&|wi, wo| Some(he.eval(wo, wi)), 4.0);
    assert!(!data.anisotropic);
    for (iso, aniso) in [
        ("ashikhmin-shirley", "ashikhmin-shirley-anisotropic"),
        ("ward", "ward-anisotropic"),
    ] {
        let opts = |models: &str| fitting::FitOptions {
            models: Some(models.into()),
            resolution: 4.0,
            max_evals: 12,
            select: None,
            ..Default::default()
        };
        let fit = |models: &str| {
            fitting::fit_material(
                &REGISTRY,
                "he",
                "m",
                &data,
                &opts(models),
                &|| false,
                &|_| {},
            )
            .unwrap()
        };
        let alone = fit(aniso).models[aniso].clone();
        let both = fit(&format!("{iso},{aniso}"));
        let contained = both.models[iso].error;
        for a in [&alone, &both.models[aniso]] {
            assert!(
                a.error <= contained,
                "{aniso}: {} worse than {iso}: {contained}",
                a.error
            );
            assert!(a.isotropic_data, "{aniso}");
            assert_eq!(a.started_from.as_ref().unwrap().model, iso);
            let w = a.warnings(aniso);
            assert!(
                w[0].contains("ANISOTROPIC MODEL ON ISOTROPIC DATA"),
                "{w:?}"
            );
        }
        // The isotropic model itself is not warned about, nor started from anything.
        assert!(!both.models[iso].isotropic_data && both.models[iso].started_from.is_none());
    }
}

#[test]
fn data_files_of_a_folder_are_sorted_and_skip_other_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for f in ["b.binary", "a.bsdf", "notes.txt", "c.fit.json"] {
        std::fs::write(d.join(f), b"x").unwrap();
    }
    let files = fitting::data_files(d).unwrap();
    let names: Vec<_> = files.iter().map(|p| fitting::stem(p)).collect();
    assert_eq!(names, ["a", "b"]);
    let empty = tempfile::tempdir().unwrap();
    let e = fitting::data_files(empty.path()).unwrap_err().to_string();
    assert!(e.contains("holds no measured data"), "{e}");
}

fn report_of(material: &str, errors: &[(&str, f64)]) -> FitReport {
    FitReport {
        format_version: report::FORMAT_VERSION,
        material: material.into(),
        source: format!("{material}.binary"),
        resolution_deg: 1.0,
        samples: 100,
        max_albedo: 0.5,
        metric: lobe_materials::fit::Metric::Eq1,
        models: errors
            .iter()
            .map(|&(m, e)| {
                let fit = ModelFit {
                    material: ward(),
                    error: e,
                    error_normalized: e / 0.5,
                    starts: 1,
                    starts_agreeing: 1,
                    evaluations: 10,
                    seconds: 0.1,
                    ..Default::default()
                };
                (m.to_string(), fit)
            })
            .collect(),
        selected: None,
        key: None,
        anisotropic: false,
    }
}

#[test]
fn merged_tables_sort_materials_and_leave_missing_models_empty() {
    let rs = [
        report_of("zinc", &[("ward", 0.02)]),
        report_of("alum", &[("ward", 0.01), ("he", 0.03)]),
        // A second report of the same material keeps its place after the first.
        // The same material fitted with another metric: a row of its own, saying which.
        FitReport {
            metric: lobe_materials::fit::Metric::CubeRoot,
            ..report_of("zinc", &[("he", 0.04)])
        },
    ];
    let t = reports::merge(&rs);
    let lines: Vec<&str> = t.csv.lines().collect();
    assert_eq!(
        lines[0],
        "material,max_albedo,metric,he error,he normalized error,ward error,ward normalized error"
    );
    assert_eq!(
        lines[1],
        "alum,0.5,eq1,3.000000e-2,6.000000e-2,1.000000e-2,2.000000e-2"
    );
    assert_eq!(lines[2], "zinc,0.5,eq1,,,2.000000e-2,4.000000e-2");
    assert_eq!(lines[3], "zinc,0.5,cube-root,4.000000e-2,8.000000e-2,,");
    let md: Vec<&str> = t.markdown.lines().collect();
    assert_eq!(md[0], "| material | metric | he | ward |");
    assert_eq!(md[2], "| alum | eq1 | 6.0000e-2 | 2.0000e-2 |");
    assert_eq!(md[3], "| zinc | eq1 |  | 4.0000e-2 |");
    assert_eq!(md[4], "| zinc | cube-root | 8.0000e-2 |  |");
}

#[test]
fn reports_are_read_in_name_order_and_a_bad_one_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    report::write(&d.join("b.fit.json"), &report_of("b", &[("ward", 0.1)])).unwrap();
    report::write(&d.join("a.fit.json"), &report_of("a", &[("he", 0.2)])).unwrap();
    std::fs::write(d.join("notes.json"), "{}").unwrap();
    let files = reports::report_files(&[d.to_path_buf()]).unwrap();
    assert_eq!(files, [d.join("a.fit.json"), d.join("b.fit.json")]);
    let read = reports::read_reports(&files).unwrap();
    assert_eq!(read[0], report_of("a", &[("he", 0.2)]));
    let mut v = report_of("c", &[("ward", 0.1)]).to_json();
    v["models"]["ward"]
        .as_object_mut()
        .unwrap()
        .remove("starts");
    std::fs::write(d.join("c.fit.json"), v.to_string()).unwrap();
    let e = reports::read_reports(&[d.join("a.fit.json"), d.join("c.fit.json")])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("c.fit.json") && e.contains("models.ward") && e.contains("starts"),
        "{e}"
    );
    let none = tempfile::tempdir().unwrap();
    assert!(reports::report_files(&[none.path().to_path_buf()]).is_err());
}

#[test]
fn report_models_are_built_and_an_absent_one_is_listed() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("r.fit.json");
    report::write(&p, &report_of("r", &[("ward", 0.1), ("he", 0.2)])).unwrap();
    let all = reports::report_models(&REGISTRY, &p, None).unwrap();
    let names: Vec<&str> = all.iter().map(|m| m.0.as_str()).collect();
    assert_eq!(names, ["he", "ward"]);
    let e = reports::report_models(&REGISTRY, &p, Some("ward,lafortune"))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("no model \"lafortune\"") && e.contains("he, ward"),
        "{e}"
    );
}

/// The number of distinct pixel colours of a figure.
fn colours(f: &Figure) -> usize {
    let mut c: Vec<&[u8]> = f.rgb.chunks_exact(3).collect();
    c.sort();
    c.dedup();
    c.len()
}

fn assert_drawn(f: &Figure, what: &str) {
    assert!(f.width >= 320 && f.height >= 320, "{what}");
    assert_eq!(f.rgb.len(), (f.width * f.height * 3) as usize, "{what}");
    assert!(colours(f) > 5, "{what}: {} colours", colours(f));
}

/// The bounding box (x0, y0, x1, y1) of the pixels of exactly colour `c` with x in
/// `columns`, if any.
fn bbox_of(f: &Figure, c: RGBColor, columns: std::ops::Range<u32>) -> Option<(u32, u32, u32, u32)> {
    let mut b: Option<(u32, u32, u32, u32)> = None;
    for y in 0..f.height {
        for x in columns.clone() {
            let k = ((y * f.width + x) * 3) as usize;
            if f.rgb[k..k + 3] == [c.0, c.1, c.2] {
                let o = b.get_or_insert((x, y, x, y));
                *o = (o.0.min(x), o.1.min(y), o.2.max(x), o.3.max(y));
            }
        }
    }
    b
}

/// True if some pixel of the figure has exactly colour `c`.
fn has_colour(f: &Figure, c: RGBColor) -> bool {
    f.rgb.chunks_exact(3).any(|p| p == [c.0, c.1, c.2])
}

fn four_model_reports() -> Vec<FitReport> {
    (0..6)
        .map(|k| {
            let e = 0.01 * (k + 1) as f64;
            report_of(
                &format!("material-with-a-rather-long-name-{k}"),
                &[
                    ("ward", 3.0 * e),
                    ("lafortune", e),
                    ("lafortune-2", e / 3.0),
                    ("cook-torrance", 2.0 * e),
                    ("cook-torrance-2", e),
                ],
            )
        })
        .collect()
}

#[test]
fn error_charts_are_drawn_with_svg_and_true_counts() {
    let rs = four_model_reports();
    let errors = figures::errors(&rs).unwrap();
    assert_drawn(&errors, "errors");
    let svg = errors.svg.as_deref().expect("a chart has an SVG");
    assert!(svg.starts_with("<svg") && svg.contains("5 models on 6 materials"));
    // Every material is named on the axis (long names shortened, never dropped).
    for k in 0..6 {
        assert!(
            svg.contains(&format!("-name-{k}\n")),
            "material {k} unnamed"
        );
    }
    // A series the reports do not hold (the microfacet estimate's) is drawn as a model,
    // with a legend entry, and decades label the axis.
    let extra: Vec<figures::ExtraError> = rs
        .iter()
        .map(|r| (r.material.clone(), "sampled-microfacet".into(), 0.05))
        .collect();
    let with = figures::errors_with(&rs, &extra).unwrap();
    let svg = with.svg.as_deref().unwrap();
    assert!(svg.contains("6 models on 6 materials"), "no extra series");
    assert!(
        svg.contains("sampled-microfacet") && svg.contains("1e-1"),
        "{svg}"
    );
    let multi = figures::multilobe(&rs).unwrap();
    assert_drawn(&multi, "multilobe");
    assert!(
        multi
            .svg
            .unwrap()
            .contains("all 6 materials with both fits")
    );
    let one_lobe = [report_of("x", &[("ward", 0.1)])];
    assert!(figures::multilobe(&one_lobe).is_err());
}

#[test]
fn a_synthetic_material_fitted_exactly_does_not_squeeze_the_measured_ones() {
    let mut rs = four_model_reports();
    let mut synthetic = report_of("builtin-plastic", &[("ward", 1e-7), ("lafortune", 0.02)]);
    synthetic.source = "built-in: {\"type\": \"ward\"}".into();
    rs.push(synthetic);
    let svg = figures::errors(&rs).unwrap().svg.unwrap();
    // The axis spans the measured materials' decades; the synthetic one is starred and its
    // exact fit written at the axis' foot.
    assert!(svg.contains("builtin-plastic*"), "not starred");
    // (normalized: the error over the max albedo, 0.5)
    assert!(
        svg.contains("\u{2193}2e-7"),
        "the value under the axis is not written"
    );
    assert!(
        !svg.contains("\n1e-7\n") && svg.contains("\n1e-1\n"),
        "axis: {svg}"
    );
}

#[test]
fn every_model_has_one_distinct_style_in_every_figure() {
    // Every reserved style differs from every other in colour or in line (a two-lobe form
    // is dashed in the colour of the one lobe it contains).
    let labels = plot::known_labels();
    let styles: Vec<plot::Style> = labels.iter().map(|l| plot::style(l)).collect();
    assert!(labels.len() >= 17);
    for (i, a) in styles.iter().enumerate() {
        for (j, b) in styles.iter().enumerate().skip(i + 1) {
            assert!(
                (a.color, a.dashed) != (b.color, b.dashed),
                "{} and {} share a colour and a line",
                labels[i],
                labels[j]
            );
        }
    }
    for (two, one) in [
        ("cook-torrance-2", "cook-torrance"),
        ("lafortune-2", "lafortune"),
    ] {
        let (a, b) = (plot::style(two), plot::style(one));
        assert!(
            a.dashed && !b.dashed && a.color == b.color,
            "{two}: {a:?}, {one}: {b:?}"
        );
    }
    // A family is one hue: the Cook-Torrance variants' hues are within 12 degrees of each
    // other, and another family's hue is farther.
    let hue = |c: plot::RGBColor| {
        let (r, g, b) = (c.0 as f64, c.1 as f64, c.2 as f64);
        let (mx, mn) = (r.max(g).max(b), r.min(g).min(b));
        let d = (mx - mn).max(1e-9);
        let h = if mx == r {
            ((g - b) / d).rem_euclid(6.0)
        } else if mx == g {
            (b - r) / d + 2.0
        } else {
            (r - g) / d + 4.0
        };
        60.0 * h
    };
    let apart = |a: f64, b: f64| (a - b).abs().min(360.0 - (a - b).abs());
    let ct = hue(plot::style("cook-torrance").color);
    for l in labels.iter().filter(|l| l.starts_with("cook-torrance")) {
        assert!(apart(hue(plot::style(l).color), ct) < 12.0, "{l}");
    }
    for other in [
        "ward",
        "lafortune",
        "blinn-phong",
        "he",
        "ashikhmin-shirley",
    ] {
        assert!(apart(hue(plot::style(other).color), ct) > 20.0, "{other}");
    }
    assert_eq!(
        hue(plot::style("ward-anisotropic").color).round(),
        hue(plot::style("ward").color).round()
    );
    // Each model is drawn in its colour in the error chart, the multi-lobe chart and a
    // polar plot, whatever the other series of the figure.
    let rs = four_model_reports();
    let errors = figures::errors(&rs).unwrap();
    let multi = figures::multilobe(&rs).unwrap();
    let fits: Vec<lobe_analysis::NamedMaterial> = ["cook-torrance-2", "lafortune"]
        .iter()
        .map(|n| (n.to_string(), material(ward())))
        .collect();
    let polar = figures::polar("ward", material(ward()).as_ref(), &fits, 30.0, 1).unwrap();
    for m in ["cook-torrance-2", "lafortune"] {
        let c = plot::style(m).color;
        for (f, what) in [
            (&errors, "errors"),
            (&multi, "multilobe"),
            (&polar, "polar"),
        ] {
            assert!(has_colour(f, c), "{m} is not drawn in its colour in {what}");
        }
    }
    assert!(has_colour(&errors, plot::style("ward").color));
}

#[test]
fn polar_and_lobe_plots_have_equal_axis_scales() {
    // A Lambertian fit is a half circle in the polar plot: twice as wide as high.
    let fits = vec![(
        "lambert".to_string(),
        material(json!({"type": "lambert", "reflectance": 0.3})),
    )];
    let polar = figures::polar("ward", material(ward()).as_ref(), &fits, 45.0, 1).unwrap();
    assert_drawn(&polar, "polar");
    let plot_w = polar.width - plot::LEGEND_W;
    let (x0, y0, x1, y1) = bbox_of(&polar, plot::style("lambert").color, 0..plot_w)
        .expect("the lambert curve is drawn");
    let (w, h) = ((x1 - x0) as f64, (y1 - y0) as f64);
    assert!((w / h - 2.0).abs() < 0.05, "half circle {w} x {h} pixels");
    assert!(figures::polar("ward", material(ward()).as_ref(), &fits, 95.0, 1).is_err());
    // The hemisphere's rim is a circle in each panel of the lobe plots.
    let lobes = figures::lobes(60.0, 30.0).unwrap();
    let items = vec![
        ("measured".to_string(), material(ward())),
        ("lafortune".to_string(), material(ward())),
        ("he".to_string(), material(ward())),
    ];
    let contours = figures::lobe_contours("ward", &items, 45.0, 0).unwrap();
    for (f, panels) in [(&lobes, 2), (&contours, 3)] {
        assert_drawn(f, "lobes");
        let pw = (f.width - plot::LEGEND_W) / panels;
        for p in 0..panels {
            let (x0, y0, x1, y1) = bbox_of(f, figures::RIM, p * pw..(p + 1) * pw).unwrap();
            let (w, h) = (x1 - x0, y1 - y0);
            assert!(
                w.abs_diff(h) <= 2 && w > 200,
                "rim {w} x {h} pixels in panel {p}"
            );
        }
    }
    let table = lobe_materials::microfacet_gen::Table::from_fn(33, |h| {
        (-(h.x * h.x + 4.0 * h.y * h.y) / 0.05).exp()
    })
    .unwrap();
    let top = figures::distribution_top(&[&table]);
    let d = figures::distribution("test", &table, top).unwrap();
    assert_eq!((d.width, d.height), (470, 420));
    assert!(colours(&d) > 5);
    // On a shared range a hundred times as high, the map is darker: its brightest colour
    // is not the ramp's top.
    let dim = figures::distribution("test", &table, 100.0 * top).unwrap();
    // (Left of the colour bar.)
    let yellow = |f: &lobe_analysis::plot::Figure| {
        f.rgb
            .chunks(3)
            .enumerate()
            .filter(|(k, c)| k % (f.width as usize) < 360 && c[0] > 200 && c[1] > 200 && c[2] < 100)
            .count()
    };
    assert!(
        yellow(&d) > 10 && yellow(&dim) == 0,
        "{} {}",
        yellow(&d),
        yellow(&dim)
    );
}

#[test]
fn sphere_grids_have_one_tile_per_material() {
    let items: Vec<lobe_analysis::NamedMaterial> = ["a", "b", "c", "d", "e"]
        .iter()
        .map(|n| (n.to_string(), material(ward())))
        .collect();
    let f = figures::spheres(&items, "builtin:studio", 8, 32, 0.0).unwrap();
    // Four per row, two rows: each cell a picture and a FLIP map under it.
    let (w, h) = figures::sphere_grid_size(5, 32);
    assert_eq!((f.width, f.height), (w, h), "spheres");
    let (_, h4) = figures::sphere_grid_size(4, 32);
    assert!(h - h4 >= 2 * 32 && w >= 4 * 32, "{w} x {h}, {h4}");
    assert!(colours(&f) > 5);
    assert!(figures::spheres(&items, "builtin:studio", 2, 16, 0.0).is_err());
}

#[test]
fn a_quick_stability_sweep_finds_nothing_non_finite() {
    let config = stability::StabilityConfig {
        models: Some(
            ["ward", "he", "lafortune", "cook-torrance", "merl"]
                .map(String::from)
                .to_vec(),
        ),
        quick: true,
        rgl: None,
    };
    let r = stability::sweep(&REGISTRY, &config).unwrap();
    let names: Vec<&str> = r.rows.iter().map(|x| x.0.as_str()).collect();
    assert_eq!(names, ["cook-torrance", "he", "lafortune", "ward", "merl"]);
    for (name, c) in &r.rows {
        assert!(c.configs > 0 && c.evals > 0, "{name}: {c:?}");
        assert_eq!((c.nonfinite, c.negative), (0, 0), "{name}: {c:?}");
    }
    assert!(r.failures().is_empty());
    let bad = stability::StabilityConfig {
        models: Some(vec!["nope".into()]),
        ..config
    };
    let e = stability::sweep(&REGISTRY, &bad).unwrap_err().to_string();
    assert!(e.contains("unknown model \"nope\""), "{e}");
}

/// A coarse isotropic binned table of a Ward material (5-degree bins).
fn write_binned(path: &Path) {
    let m = material(ward());
    let mut t = Binned::empty(
        false,
        vec![
            Axis::new(18, 0.0, 90.0),
            Axis::new(18, 0.0, 90.0),
            Axis::new(36, 0.0, 180.0),
        ],
    );
    for k in 0..t.len() {
        let (wi, wo) = t.directions(k);
        let f = m.eval(wo, wi);
        t.values[k] = Some([f.r, f.g, f.b]);
    }
    t.write(path).unwrap();
}

#[test]
fn a_tiny_tradeoff_study_measures_every_representation() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("w.bin");
    write_binned(&data);
    let config = tradeoff::TradeoffConfig {
        data,
        scene: None,
        reference_spp: 32,
        spp: 16,
        size: 16,
        resolution: 5.0,
        models: Some("ward".into()),
        output: dir.path().join("t"),
    };
    let lines = std::sync::Mutex::new(Vec::new());
    let s = tradeoff::study(&REGISTRY, &config, &|l| lines.lock().unwrap().push(l)).unwrap();
    let names: Vec<&str> = s.rows.iter().map(|r| r.name.as_str()).collect();
    assert_eq!(names, ["measured", "sampled-microfacet", "ward"]);
    for r in &s.rows {
        for v in [r.rmse, r.robust_rmse, r.flip, r.equal_time_rmse, r.seconds] {
            assert!(v.is_finite() && v >= 0.0, "{}: {r:?}", r.name);
        }
        assert!(r.eval_ns > 0.0 && r.memory > 0, "{}: {r:?}", r.name);
        assert!(r.curve.len() >= 3, "{}: {r:?}", r.name);
    }
    // Ward data fits Ward almost exactly.
    assert!(
        s.rows[2].brdf_error < 1e-3 * s.max_albedo,
        "{:?}",
        s.rows[2]
    );
    assert_eq!(s.budget, s.rows[0].seconds);
    assert!(dir.path().join("t-microfacet.exr").is_file());
    assert!(
        lines
            .lock()
            .unwrap()
            .iter()
            .any(|l| l.contains("fitted ward"))
    );
    let md = tradeoff::markdown(&s);
    assert_eq!(md.lines().filter(|l| l.starts_with("| ward |")).count(), 1);
    assert_eq!(tradeoff::csv(&s).lines().count(), 4);
    tradeoff::write(&s, &config.output).unwrap();
    assert!(dir.path().join("t.png").is_file() && dir.path().join("t.csv").is_file());
    let bad = tradeoff::TradeoffConfig { spp: 8, ..config };
    assert!(tradeoff::study(&REGISTRY, &bad, &|_| {}).is_err());
}

#[test]
fn the_synthetic_microfacet_experiment_recovers_the_structure() {
    let shape = lobe_materials::microfacet_gen::Shape::synthetic("brushed").unwrap();
    let config = lobe_analysis::microfacet::SynthConfig {
        nodes: 33,
        f0: Some(1.0),
        iterations: 2,
        resolution: 10.0,
        filled: 0.5,
    };
    let s = lobe_analysis::microfacet::synth(&REGISTRY, &shape, "brushed", &config).unwrap();
    let labels: Vec<&str> = s.rows.iter().map(|r| r.0.as_str()).collect();
    assert_eq!(labels[0], "sampled-microfacet (estimated p)");
    assert_eq!(labels[1..], *models::ANISOTROPIC_DEFAULT);
    assert!(
        s.rows.iter().all(|r| r.1.is_finite() && r.1 > 0.0),
        "{:?}",
        s.rows
    );
    assert!(s.correlation > 0.8, "correlation {}", s.correlation);
    assert!(!s.data.samples.is_empty());
    assert!(s.rows[1..].iter().all(|r| !r.3.is_empty()), "{:?}", s.rows);
}

#[test]
fn a_vanished_specular_lobe_is_named() {
    use lobe_analysis::microfacet::lobe_note;
    let vanished = json!({"type": "ward-anisotropic", "diffuse": [0.2, 0.1, 0.1], "specular": [0.0, 0.0, 0.0]});
    assert!(lobe_note(&vanished).contains("vanished"));
    let kept = json!({"type": "ward-anisotropic", "specular": [0.0, 0.25, 0.0]});
    assert_eq!(lobe_note(&kept), "specular [0.000, 0.250, 0.000]");
}

#[test]
fn a_batch_fits_its_shard_skips_finished_reports_and_reports_failures() {
    let dir = tempfile::tempdir().unwrap();
    let (data, out) = (dir.path().join("data"), dir.path().join("reports"));
    std::fs::create_dir(&data).unwrap();
    for n in ["a", "b", "c"] {
        write_binned(&data.join(format!("{n}.bin")));
    }
    std::fs::write(data.join("d.bin"), b"not binned data").unwrap();
    // Shard 1 of 2: b and d.
    let jobs = fitting::batch_jobs(&data, &out, (1, 2)).unwrap();
    let names: Vec<String> = jobs.iter().map(|j| fitting::stem(&j.0)).collect();
    assert_eq!(names, ["b", "d"]);
    assert_eq!(jobs[0].1, out.join("b.fit.json"));
    let opts = fitting::FitOptions {
        models: Some("ward".into()),
        resolution: 5.0,
        max_evals: 40,
        select: None,
        ..Default::default()
    };
    struct Count(AtomicUsize);
    impl fitting::BatchProgress for Count {
        fn fitted(&self, _: &str, _: &FitResult) {
            self.0.fetch_add(1, Ordering::Relaxed);
        }
    }
    let count = Count(AtomicUsize::new(0));
    let s = fitting::fit_batch(&REGISTRY, &jobs, &opts, &|| false, &count);
    assert_eq!((s.done, s.skipped), (1, 0));
    assert_eq!(s.failures.len(), 1);
    assert!(s.failures[0].contains("d.bin"), "{:?}", s.failures);
    assert_eq!(count.0.load(Ordering::Relaxed), 1);
    assert!(report::read(&out.join("b.fit.json")).unwrap().models["ward"].error < 1e-3);
    // A rerun skips the finished report and retries the failure.
    let again = fitting::fit_batch(&REGISTRY, &jobs, &opts, &|| false, &count);
    assert_eq!((again.done, again.skipped, again.failures.len()), (0, 1, 1));
    // A report path that looks like a file is refused.
    assert!(fitting::batch_jobs(&data, &dir.path().join("x.fit.json"), (0, 1)).is_err());
}
