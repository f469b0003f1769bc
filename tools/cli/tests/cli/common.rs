//! What the command-line tests share: the binary, a small scene, and the helpers that run
//! it, write inputs and check refusals.

use std::path::Path;
use std::process::Command;

pub use lobe_tests::listing;

pub fn lobe() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lobe"))
}

pub const SCENE: &str = r#"{
  "camera": {"type": "perspective", "fov": 40, "origin": [0, 0, 4], "target": [0, 0, 0]},
  "film": {"width": 16, "height": 12},
  "sampler": {"spp": 4},
  "shapes": [{"type": "sphere"}],
  "lights": [{"type": "envmap", "file": "builtin:studio"}]
}"#;

pub fn fails(args: &[&str], needle: &str) {
    let o = lobe().args(args).output().unwrap();
    assert!(!o.status.success(), "{args:?} succeeded");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(stderr.contains(needle), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"));
}

/// Writes isotropic binned data of `material` (no acquisition noise, every bin filled):
/// `n_theta` bins of theta_i and theta_o over 0-80 degrees, `n_phi` of phi_d over 0-180.
pub fn write_binned(material: serde_json::Value, (n_theta, n_phi): (usize, usize), path: &Path) {
    use lobe_materials::measured::binned::{Axis, Binned};
    let mat = lobe_materials::registry::Registry::builtin()
        .create(&material, "m")
        .unwrap();
    let mut b = Binned::empty(
        false,
        vec![
            Axis::new(n_theta, 0.0, 80.0),
            Axis::new(n_theta, 0.0, 80.0),
            Axis::new(n_phi, 0.0, 180.0),
        ],
    );
    for i in 0..b.len() {
        let (wi, wo) = b.directions(i);
        b.values[i] = Some(mat.eval(wo, wi).to_array());
    }
    b.write(path).unwrap();
}

/// Sends SIGINT (what Ctrl-C sends) to `child`.
pub fn sigint(child: &std::process::Child) {
    #[cfg(unix)]
    {
        let pid = libc::pid_t::try_from(child.id()).unwrap();
        // SAFETY: kill(2) has no memory-safety preconditions.
        let ok = unsafe { libc::kill(pid, libc::SIGINT) } == 0;
        assert!(ok, "kill -INT {pid} failed");
    }
    #[cfg(not(unix))]
    {
        let ok = Command::new("kill")
            .args(["-INT", &child.id().to_string()])
            .status()
            .unwrap()
            .success();
        assert!(ok, "kill -INT failed");
    }
}

/// Runs lobe in `dir`.
pub fn lobe_in(dir: &Path, args: &[&str]) -> std::process::Output {
    lobe().current_dir(dir).args(args).output().unwrap()
}

/// Runs lobe in `dir` and checks that it fails with one line holding every needle.
pub fn refused_in(dir: &Path, args: &[&str], needles: &[&str]) {
    let o = lobe_in(dir, args);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{args:?} succeeded: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{args:?}: {stderr}");
    for n in needles {
        assert!(stderr.contains(n), "{args:?}: no \"{n}\" in {stderr}");
    }
}

/// A small linear EXR of `w` x `h` pixels of value `v`.
pub fn write_exr(path: &Path, (w, h): (u32, u32), v: f32) {
    let px = vec![lobe_renderer::Rgb::splat(v); (w * h) as usize];
    lobe_renderer::image_io::write_exr(path, w, h, &px).unwrap();
}

pub const WARD: &str = r#"{"type": "ward", "diffuse": 0.1, "specular": 0.2, "alpha": 0.2}"#;

/// A full MERL table (35 MB) of the Ward material [`WARD`].
pub fn write_merl(path: &Path) {
    let ward = lobe_materials::registry::Registry::builtin()
        .create(&serde_json::from_str(WARD).unwrap(), "m")
        .unwrap();
    lobe_materials::measured::tabulate::merl_from(&|wo, wi| ward.eval(wo, wi), &Default::default())
        .write(path)
        .unwrap();
}

/// ../shared/data next to the repository, if present.
pub fn shared_data() -> Option<std::path::PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    p.is_dir().then_some(p)
}
