//! `lobe eval`: f_r (RGB, 1/sr) and the sampling pdf of any material at direction pairs
//! (theta_i phi_i theta_o phi_o, degrees) read from stdin or laid out on a grid, as CSV.

use crate::material::{MaterialArgs, load_material};
use lobe_materials::Bsdf;
use lobe_materials::frame::spherical_direction;
use lobe_renderer::Error;
use std::io::{BufRead, Write};

#[derive(clap::Args)]
pub struct EvalArgs {
    #[command(flatten)]
    pub material: MaterialArgs,
    /// Regular grid instead of stdin: four comma-separated fields theta_i,phi_i,theta_o,phi_o,
    /// each a value or START..STOP..STEP (degrees, STOP included when on the grid).
    #[arg(long)]
    grid: Option<String>,
}

/// Values of one grid field: `x` or `a..b..step`.
fn field(s: &str, which: &str) -> Result<Vec<f64>, Error> {
    let bad = || {
        Error::Other(format!(
            "--grid: {which}: expected a number or START..STOP..STEP in degrees, found \"{s}\""
        ))
    };
    let parts: Vec<&str> = s.split("..").collect();
    let num = |x: &str| crate::args::finite::<f64>(x).map_err(|_| bad());
    match parts.as_slice() {
        [x] => Ok(vec![num(x)?]),
        [a, b, st] => {
            let (a, b, st) = (num(a)?, num(b)?, num(st)?);
            if !(st > 0.0) || !(b >= a) || (b - a) / st > 1e6 {
                return Err(bad());
            }
            let n = ((b - a) / st + 1e-9).floor() as usize;
            Ok((0..=n).map(|k| a + k as f64 * st).collect())
        }
        _ => Err(bad()),
    }
}

fn grid(spec: &str) -> Result<Vec<[f64; 4]>, Error> {
    let f: Vec<&str> = spec.split(',').collect();
    if f.len() != 4 {
        return Err(Error::Other(format!(
            "--grid: expected 4 comma-separated fields theta_i,phi_i,theta_o,phi_o, found {}",
            f.len()
        )));
    }
    let (ti, pi, to, po) = (
        field(f[0], "theta_i")?,
        field(f[1], "phi_i")?,
        field(f[2], "theta_o")?,
        field(f[3], "phi_o")?,
    );
    let mut out = Vec::new();
    for &a in &ti {
        for &b in &pi {
            for &c in &to {
                for &d in &po {
                    out.push([a, b, c, d]);
                }
            }
        }
    }
    Ok(out)
}

fn row(out: &mut impl Write, m: &dyn Bsdf, a: [f64; 4]) -> std::io::Result<()> {
    let wi = spherical_direction(a[0].to_radians() as f32, a[1].to_radians() as f32);
    let wo = spherical_direction(a[2].to_radians() as f32, a[3].to_radians() as f32);
    let f = m.eval(wo, wi);
    let pdf = m.pdf(wo, wi);
    writeln!(
        out,
        "{},{},{},{},{:e},{:e},{:e},{:e}",
        a[0], a[1], a[2], a[3], f.r, f.g, f.b, pdf
    )
}

pub fn cmd_eval(args: EvalArgs) -> Result<(), Error> {
    let m = load_material(&args.material)?;
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let io = |e: std::io::Error| Error::Other(format!("cannot write the output: {e}"));
    writeln!(out, "theta_i,phi_i,theta_o,phi_o,f_r,f_g,f_b,pdf").map_err(io)?;
    if let Some(g) = &args.grid {
        for a in grid(g)? {
            row(&mut out, m.as_ref(), a).map_err(io)?;
        }
    } else {
        for (k, line) in std::io::stdin().lock().lines().enumerate() {
            let line = line.map_err(|e| Error::Other(format!("stdin: {e}")))?;
            let t = line.trim();
            if t.is_empty() || t.starts_with('#') {
                continue;
            }
            let nums: Vec<f64> = t.split(|c: char| c.is_whitespace() || c == ',').filter(|s| !s.is_empty()).map(|s| s.parse()).collect::<Result<_, _>>().map_err(|_| {
                Error::Other(format!("stdin: line {}: expected 4 angles in degrees (theta_i phi_i theta_o phi_o), found \"{t}\"", k + 1))
            })?;
            if nums.len() != 4 || nums.iter().any(|x| !x.is_finite()) {
                return Err(Error::Other(format!(
                    "stdin: line {}: expected 4 finite angles in degrees (theta_i phi_i theta_o phi_o), found \"{t}\"",
                    k + 1
                )));
            }
            row(&mut out, m.as_ref(), [nums[0], nums[1], nums[2], nums[3]]).map_err(io)?;
        }
    }
    out.flush().map_err(io)
}
