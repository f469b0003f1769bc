//! What every command shares on its command line: the value parser of numeric options
//! (NaN and infinity are refused by clap itself, naming the option), and the Ctrl-C
//! handling (the first Ctrl-C asks the running work to stop and says so, a second one
//! exits at once with status 130).

use lobe_renderer::Error;
use std::str::FromStr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

/// Parses a finite number: every floating-point option uses it
/// (`#[arg(value_parser = finite::<f64>)]`).
pub fn finite<T: FromStr + Into<f64> + Copy>(s: &str) -> Result<T, String> {
    let v: T = s
        .trim()
        .parse()
        .map_err(|_| format!("expected a number, found \"{s}\""))?;
    if v.into().is_finite() {
        return Ok(v);
    }
    // A finite number that overflowed the option's type (1e308 for an f32 option).
    match s.trim().parse::<f64>() {
        Ok(x) if x.is_finite() => Err(format!(
            "{s} is beyond the option's precision (at most {:e}); expected a smaller finite number",
            f32::MAX
        )),
        _ => Err(format!(
            "expected a finite number, found \"{s}\" (NaN and infinity are not accepted)"
        )),
    }
}

/// Checks a samples-per-pixel option (`--spp`, `--reference-spp`): 1 to
/// [`lobe_renderer::limits::MAX_SPP`], the limit of scene files.
pub fn check_spp(option: &str, spp: u32) -> Result<u32, Error> {
    let max = lobe_renderer::limits::MAX_SPP;
    if spp == 0 || spp > max {
        return Err(Error::Other(format!(
            "{option}: expected a positive number of samples per pixel of at most {max} (2^24, as in scene files), found {spp}"
        )));
    }
    Ok(spp)
}

static CANCEL: OnceLock<Arc<AtomicBool>> = OnceLock::new();

/// The flag an interrupt sets, with the handler installed on first use. Ctrl-C (SIGINT),
/// SIGTERM (sent by `timeout`, Slurm and Kubernetes) and SIGHUP are handled alike: the
/// first sets the flag, stops every later commit of outputs
/// ([`lobe_materials::io::interrupt_outputs`]) and prints `lobe: ACK` on stderr (what
/// happens now); a second one exits with status 130 at once, waiting only for a set of
/// outputs being moved into place, so that no set is left half replaced. An interrupt
/// that arrives while a set is being moved into place lets it complete and says so.
pub fn ctrl_c(ack: &'static str) -> Arc<AtomicBool> {
    CANCEL
        .get_or_init(|| {
            let flag = Arc::new(AtomicBool::new(false));
            let f = flag.clone();
            // Without a handler (one is already set), work simply cannot be cancelled.
            let _ = ctrlc::set_handler(move || {
                if f.swap(true, Ordering::SeqCst) {
                    lobe_materials::io::wait_for_commit();
                    eprintln!("lobe: aborted");
                    std::process::exit(130);
                }
                if lobe_materials::io::interrupt_outputs() {
                    eprintln!(
                        "lobe: interrupted while the outputs were moved into place; they are complete"
                    );
                } else {
                    eprintln!("lobe: {ack}");
                }
            });
            flag
        })
        .clone()
}

/// True once Ctrl-C was pressed (the command then exits with status 130).
pub fn cancelled() -> bool {
    CANCEL.get().is_some_and(|f| f.load(Ordering::SeqCst))
}

/// Parses `--shard I/N` (0 <= I < N): this task's share of a job array.
pub fn parse_shard(s: &str) -> Result<(usize, usize), Error> {
    let bad = || {
        Error::Other(format!(
            "--shard: expected I/N with 0 <= I < N, found \"{s}\""
        ))
    };
    let (i, n) = s.split_once('/').ok_or_else(bad)?;
    let (i, n): (usize, usize) = (
        i.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if n == 0 || i >= n {
        return Err(bad());
    }
    Ok((i, n))
}
