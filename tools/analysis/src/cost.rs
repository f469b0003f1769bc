//! The cost of a material per call: nanoseconds per `eval` and per `sample` over a fixed set
//! of 32768 cosine-distributed direction pairs, the best of three passes (what the
//! trade-off weighs against accuracy), and the committed per-model table of such costs
//! ([`reference_cost`], `model_costs.json`) that model selection ranks by, so that the same
//! inputs select the same model on every run and every machine.

use lobe_materials::Bsdf;
use lobe_materials::sampling::warp::square_to_cosine_hemisphere;

/// Time per call of a material's evaluation and sampling.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cost {
    /// Nanoseconds per `eval`.
    pub eval_ns: f64,
    /// Nanoseconds per `sample`.
    pub sample_ns: f64,
}

impl Cost {
    /// Eval and sample time together.
    pub fn total(&self) -> f64 {
        self.eval_ns + self.sample_ns
    }
}

/// One timing case: wo, wi, the 2D and 1D sample.
type Case = (glam::Vec3, glam::Vec3, glam::Vec2, f32);

/// The fixed cases (a deterministic LCG), the same for every material.
fn cases(n: usize) -> Vec<Case> {
    let mut state = 0x853c49e6748fea9bu64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 40) as f32 + 0.5) / (1u64 << 24) as f32
    };
    (0..n)
        .map(|_| {
            let a = square_to_cosine_hemisphere(glam::Vec2::new(next(), next()));
            let b = square_to_cosine_hemisphere(glam::Vec2::new(next(), next()));
            (a, b, glam::Vec2::new(next(), next()), next())
        })
        .collect()
}

/// Measures the time per eval and per sample of `b`.
pub fn measure(b: &dyn Bsdf) -> Cost {
    let n = 1 << 15;
    let dirs = cases(n);
    let time = |f: &dyn Fn(&Case) -> f32| {
        let mut best = f64::INFINITY;
        for _ in 0..3 {
            let t = std::time::Instant::now();
            let mut acc = 0.0f32;
            for d in &dirs {
                acc += f(d);
            }
            std::hint::black_box(acc);
            best = best.min(t.elapsed().as_secs_f64() * 1e9 / n as f64);
        }
        best
    };
    Cost {
        eval_ns: time(&|d| b.eval(d.0, d.1).r),
        sample_ns: time(&|d| b.sample(d.0, d.2, d.3).map_or(0.0, |s| s.pdf)),
    }
}

/// The committed cost table: per fit label (`lobe fit --list`), nanoseconds per eval and
/// per sample of that model at default parameters (two lobes and a diffuse term for the
/// two-lobe variants), the median of five [`measure`]s on one machine. Regenerate it with
/// `cargo test --release -p lobe-analysis --test model_costs -- --ignored` after a change
/// that moves a model's speed; a test checks that every fit label has an entry.
pub const MODEL_COSTS_JSON: &str = include_str!("model_costs.json");

/// The committed cost of the fit variant `label` ([`MODEL_COSTS_JSON`]), if it has one.
pub fn reference_cost(label: &str) -> Option<Cost> {
    static TABLE: std::sync::LazyLock<serde_json::Value> = std::sync::LazyLock::new(|| {
        serde_json::from_str(MODEL_COSTS_JSON).expect("model_costs.json is valid JSON")
    });
    let e = TABLE.get("models")?.get(label)?;
    Some(Cost {
        eval_ns: e.get("eval_ns")?.as_f64()?,
        sample_ns: e.get("sample_ns")?.as_f64()?,
    })
}
