//! Criterion benchmarks of every material's evaluation and sampling, one at a time and
//! batched, in ns per call: the analytic models (each with a Lambertian, as rendered), the
//! RGL measured files of the shared data (skipped with a message when absent), a MERL
//! table and the study's binned data tabulated from an analytic model at start, and the
//! sampled-microfacet generator. Per material: `eval`, `eval+pdf` (the two scalar calls
//! the renderer's next-event estimation needs), `eval_pdf_many` (the same, batched),
//! `sample` and `sample_many`, over 256 fixed pseudo-random queries on the upper
//! hemisphere. At the end it prints the figures as a Markdown table (docs/performance.md,
//! "BSDF kernels"). Filter as usual: `cargo bench -p lobe-materials --bench bsdf -- rgl`.

use criterion::{Criterion, Throughput};
use glam::{Vec2, Vec3};
use lobe_materials::measured::tabulate::{Acquisition, binned_from, merl_from};
use lobe_materials::registry::Registry;
use lobe_materials::{Bsdf, BsdfSamples, Rgb, Vec3s};
use serde_json::{Value, json};
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, SystemTime};

/// Queries per iteration.
const N: usize = 256;

/// The benchmark's queries: directions cosine-distributed over the upper hemisphere and
/// uniform samples, from a fixed 64-bit LCG.
struct Queries {
    wo: Vec<Vec3>,
    wi: Vec<Vec3>,
    u: Vec<Vec2>,
    uc: Vec<f32>,
}

fn queries() -> Queries {
    let mut s = 0x853c_49e6_748f_ea9bu64;
    let mut rnd = move || {
        s = s
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((s >> 40) as f32 + 0.5) / (1u64 << 24) as f32
    };
    let mut dir =
        || lobe_materials::sampling::warp::square_to_cosine_hemisphere(Vec2::new(rnd(), rnd()));
    let wo: Vec<Vec3> = (0..N).map(|_| dir()).collect();
    let wi: Vec<Vec3> = (0..N).map(|_| dir()).collect();
    let u = (0..N).map(|_| Vec2::new(rnd(), rnd())).collect();
    let uc = (0..N).map(|_| rnd()).collect();
    Queries { wo, wi, u, uc }
}

fn analytic() -> Vec<(&'static str, Value)> {
    vec![
        ("lambert", json!({"type": "lambert", "reflectance": 0.5})),
        (
            "ward",
            json!({"type": "ward", "diffuse": 0.2, "specular": 0.1, "alpha": 0.1}),
        ),
        (
            "ward-anisotropic",
            json!({"type": "ward-anisotropic", "diffuse": 0.2, "specular": 0.1, "alpha_x": 0.05, "alpha_y": 0.2}),
        ),
        (
            "ward-duer",
            json!({"type": "ward-duer", "diffuse": 0.2, "specular": 0.1, "alpha": 0.1}),
        ),
        (
            "blinn-phong",
            json!({"type": "blinn-phong", "diffuse": 0.2, "specular": 0.1, "n": 300}),
        ),
        (
            "cook-torrance",
            json!({"type": "cook-torrance", "diffuse": 0.2, "specular": 0.1, "m": 0.1}),
        ),
        (
            "lafortune",
            json!({"type": "lafortune", "diffuse": 0.2, "specular": 0.1, "n": 100}),
        ),
        (
            "ashikhmin-shirley",
            json!({"type": "ashikhmin-shirley", "diffuse": 0.2, "specular": 0.1, "n": 300, "f0": 0.05}),
        ),
        (
            "ashikhmin-shirley-anisotropic",
            json!({"type": "ashikhmin-shirley-anisotropic", "diffuse": 0.2, "specular": 0.1, "nu": 50, "nv": 800, "f0": 0.05}),
        ),
        (
            "he",
            json!({"type": "he", "diffuse": 0.2, "specular": 1, "sigma0": 0.18, "tau": 3, "eta": 1.5}),
        ),
        (
            "he-rough",
            json!({"type": "he", "diffuse": 0.2, "specular": 1, "sigma0": 3.0, "tau": 28, "eta": 1.5}),
        ),
        (
            "poulin-fournier",
            json!({"type": "poulin-fournier", "diffuse": 0.2, "specular": 0.1, "n": 3000, "d": 0.18, "h": 0.5}),
        ),
        (
            "sampled-microfacet",
            json!({"type": "sampled-microfacet", "diffuse": 0.2, "specular": 0.5, "distribution": "satin", "f0": 0.5}),
        ),
    ]
}

/// The shared data folder: `LOBE_DATA`, or `shared/data` beside the workspace.
fn shared_data() -> Option<PathBuf> {
    if let Ok(p) = std::env::var("LOBE_DATA") {
        let p = PathBuf::from(p);
        if p.is_dir() {
            return Some(p);
        }
    }
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    p.is_dir().then_some(p)
}

/// The RGL materials of the shared data, or none (with a message) when it is absent.
fn rgl() -> Vec<(String, Value)> {
    let Some(data) = shared_data() else {
        eprintln!("RGL benchmarks SKIPPED: ../shared/data (or LOBE_DATA) is absent");
        return Vec::new();
    };
    [
        "cc_ibiza_sunset",
        "colodur_napoli_4f",
        "paper_white",
        "vch_golden_yellow",
    ]
    .iter()
    .filter_map(|name| {
        let path = data.join("rgl").join(format!("{name}_rgb.bsdf"));
        if !path.is_file() {
            eprintln!(
                "RGL benchmark of {name} SKIPPED: {} is absent",
                path.display()
            );
            return None;
        }
        Some((
            format!("rgl-{name}"),
            json!({"type": "rgl", "file": path.to_str()?}),
        ))
    })
    .collect()
}

/// A MERL table and the study's isotropic binned data tabulated from a glossy
/// Cook-Torrance material, written to `dir`.
fn tabulated(reg: &Registry, dir: &Path) -> Vec<(String, Value)> {
    let source = reg
        .create(
            &json!({"type": "cook-torrance", "diffuse": [0.3, 0.2, 0.1], "specular": 0.2, "m": 0.15}),
            "source",
        )
        .expect("valid");
    let f = |wo: Vec3, wi: Vec3| source.eval(wo, wi);
    let merl = dir.join("cook-torrance.binary");
    merl_from(&f, &Acquisition::default())
        .write(&merl)
        .expect("writable temporary folder");
    let binned = dir.join("cook-torrance.lobebin");
    binned_from(&f, false, &Acquisition::default())
        .write(&binned)
        .expect("writable temporary folder");
    vec![
        (
            "merl".to_string(),
            json!({"type": "merl", "file": merl.to_str().expect("utf-8 path")}),
        ),
        (
            "binned".to_string(),
            json!({"type": "binned", "file": binned.to_str().expect("utf-8 path")}),
        ),
    ]
}

fn bench_material(c: &mut Criterion, name: &str, m: &Arc<dyn Bsdf>, q: &Queries) {
    let mut g = c.benchmark_group(format!("bsdf/{name}"));
    g.throughput(Throughput::Elements(N as u64));
    g.bench_function("eval", |b| {
        b.iter(|| {
            for (&wo, &wi) in q.wo.iter().zip(&q.wi) {
                black_box(m.eval(black_box(wo), black_box(wi)));
            }
        })
    });
    g.bench_function("eval+pdf", |b| {
        b.iter(|| {
            for (&wo, &wi) in q.wo.iter().zip(&q.wi) {
                black_box(m.eval(black_box(wo), black_box(wi)));
                black_box(m.pdf(black_box(wo), black_box(wi)));
            }
        })
    });
    let (mut f, mut pdf) = (vec![Rgb::ZERO; N], vec![0.0f32; N]);
    let (wo, wi) = (Vec3s::from(&q.wo[..]), Vec3s::from(&q.wi[..]));
    let u = lobe_materials::Vec2s::from(&q.u[..]);
    g.bench_function("eval_pdf_many", |b| {
        b.iter(|| {
            m.eval_pdf_many(black_box(wo.cols()), black_box(wi.cols()), &mut f, &mut pdf);
            black_box((&f, &pdf));
        })
    });
    g.bench_function("sample", |b| {
        b.iter(|| {
            for ((&wo, &u), &uc) in q.wo.iter().zip(&q.u).zip(&q.uc) {
                black_box(m.sample(black_box(wo), black_box(u), black_box(uc)));
            }
        })
    });
    let mut out = BsdfSamples::new(N);
    g.bench_function("sample_many", |b| {
        b.iter(|| {
            m.sample_many(
                black_box(wo.cols()),
                black_box(u.cols()),
                black_box(&q.uc),
                out.cols_mut(),
            );
            black_box(&out);
        })
    });
    g.finish();
}

const KINDS: [&str; 5] = ["eval", "eval+pdf", "eval_pdf_many", "sample", "sample_many"];

/// Criterion's output folder, found as criterion finds it: `CRITERION_HOME`, else
/// `CARGO_TARGET_DIR/criterion`, else (run by cargo) the workspace's `target/criterion`,
/// else `target/criterion` in the current folder.
fn criterion_dir() -> PathBuf {
    if let Some(p) = std::env::var_os("CRITERION_HOME") {
        return PathBuf::from(p);
    }
    if let Some(p) = std::env::var_os("CARGO_TARGET_DIR") {
        return PathBuf::from(p).join("criterion");
    }
    if std::env::var_os("CARGO").is_some() {
        return Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/criterion");
    }
    PathBuf::from("target/criterion")
}

/// Mean ns per call of one benchmark, when criterion wrote it during this run.
fn ns_per_call(dir: &Path, group: &str, kind: &str, since: SystemTime) -> Option<f64> {
    // Criterion replaces characters that are not safe in file names ('/' here) by '_'.
    let safe = |s: &str| s.replace('/', "_");
    let file = dir
        .join(safe(group))
        .join(safe(kind))
        .join("new/estimates.json");
    if std::fs::metadata(&file).ok()?.modified().ok()? < since {
        return None;
    }
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&file).ok()?).ok()?;
    Some(v["mean"]["point_estimate"].as_f64()? / N as f64)
}

/// Prints the figures of this run as a Markdown table.
fn print_table(names: &[String], since: SystemTime) {
    let dir = criterion_dir();
    let mut rows = Vec::new();
    for name in names {
        let cells: Vec<Option<f64>> = KINDS
            .iter()
            .map(|k| ns_per_call(&dir, &format!("bsdf/{name}"), k, since))
            .collect();
        if cells.iter().any(Option::is_some) {
            let fmt = |c: &Option<f64>| c.map_or("-".to_string(), |v| format!("{v:.1}"));
            rows.push(format!(
                "| {name} | {} |",
                cells.iter().map(fmt).collect::<Vec<_>>().join(" | ")
            ));
        }
    }
    if rows.is_empty() {
        println!("(no figures found under {})", dir.display());
        return;
    }
    println!("\nns per call ({N} queries per iteration):\n");
    println!("| material | {} |", KINDS.join(" | "));
    println!("|---|{}", "---|".repeat(KINDS.len()));
    for r in rows {
        println!("{r}");
    }
}

/// Whether the command line's filters (criterion's positional arguments) can select a
/// benchmark of material `name`: a filter that is part of `bsdf/NAME/KIND` or names it.
/// Tables are tabulated and read only for the materials a run benchmarks.
fn wanted(name: &str) -> bool {
    let filters: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let id = format!("bsdf/{name}/");
    filters.is_empty()
        || filters
            .iter()
            .any(|f| id.contains(f.as_str()) || f.contains(name))
}

fn main() {
    let since = SystemTime::now() - Duration::from_secs(1);
    let mut c = Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(1))
        .sample_size(20)
        .configure_from_args();
    let reg = Registry::builtin();
    let q = queries();
    let tmp = tempfile::tempdir().expect("a temporary folder");
    let mut materials: Vec<(String, Value)> = analytic()
        .into_iter()
        .map(|(n, v)| (n.to_string(), v))
        .collect();
    materials.extend(rgl());
    if wanted("merl") || wanted("binned") {
        materials.extend(tabulated(&reg, tmp.path()));
    }
    let mut names = Vec::new();
    for (name, desc) in materials.into_iter().filter(|(n, _)| wanted(n)) {
        let m = reg
            .create(&desc, "bench")
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        bench_material(&mut c, &name, &m, &q);
        names.push(name);
    }
    c.final_summary();
    print_table(&names, since);
}
