//! What every command owes its user: one-line errors, limits, Ctrl-C, read-only and full disks, outputs that are never inputs, help texts and README commands that work.

use super::common::*;
use std::path::Path;
use std::process::Command;

#[test]
fn bad_input_is_one_line_and_non_zero() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.json");
    std::fs::write(&scene, SCENE).unwrap();
    let s = scene.to_str().unwrap();
    fails(&["render", "/nonexistent/scene.json"], "does not exist");
    fails(&["render", dir.path().to_str().unwrap()], "is a directory");
    let missing_dir = dir.path().join("no/such/dir/out.exr");
    fails(
        &["render", s, "-o", missing_dir.to_str().unwrap()],
        "output folder",
    );
    fails(&["render", s, "--spp", "0"], "--spp");
    fails(&["render", s, "--threads", "0"], "--threads");
    let empty = dir.path().join("empty.json");
    std::fs::write(&empty, "").unwrap();
    fails(&["render", empty.to_str().unwrap()], "is empty");
}

#[test]
fn resource_limits_are_one_line_errors_not_aborts() {
    use std::os::unix::process::ExitStatusExt;
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.json");
    std::fs::write(&scene, SCENE).unwrap();
    let s = scene.to_str().unwrap();
    let out = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    // Far more threads than any machine: refused at once (it ran for minutes).
    fails(
        &["render", s, "-o", &out("t.exr"), "--threads", "10000"],
        "expected 1 to 1024",
    );
    // Threads beyond the tile count are not started, and never change the image.
    let (a, b) = (out("one.exr"), out("many.exr"));
    for (o, t) in [(&a, "1"), (&b, "1000")] {
        let r = lobe()
            .args(["render", s, "-o", o, "--threads", t])
            .output()
            .unwrap();
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    }
    let (ia, ib) = (
        lobe_renderer::image_io::read_exr(Path::new(&a)).unwrap(),
        lobe_renderer::image_io::read_exr(Path::new(&b)).unwrap(),
    );
    assert!(ia.pixels == ib.pixels);
    // A 16384^2 film (6 GiB) under a 2 GiB address-space limit: a clean error, no abort.
    let big = dir.path().join("big.json");
    std::fs::write(
        &big,
        SCENE.replace(
            r#""width": 16, "height": 12"#,
            r#""width": 16384, "height": 16384"#,
        ),
    )
    .unwrap();
    match Command::new("prlimit")
        .arg("--as=2147483648")
        .arg(env!("CARGO_BIN_EXE_lobe"))
        .args([
            "render",
            big.to_str().unwrap(),
            "-o",
            &out("big.exr"),
            "--spp",
            "1",
        ])
        .output()
    {
        Ok(r) => {
            let stderr = String::from_utf8_lossy(&r.stderr);
            assert_eq!(r.status.signal(), None, "killed by a signal: {stderr}");
            assert_eq!(r.status.code(), Some(1), "{stderr}");
            assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
            assert!(
                stderr.contains("16384x16384 film") && stderr.contains("memory"),
                "{stderr}"
            );
            assert!(!dir.path().join("big.exr").exists());
        }
        Err(e) => eprintln!("prlimit unavailable ({e}): memory-limit case skipped"),
    }
}

#[test]
fn ctrl_c_stops_a_render_without_output_and_a_batch_fit_without_losing_reports() {
    let dir = tempfile::tempdir().unwrap();
    // A render long enough to be interrupted.
    let scene = dir.path().join("s.json");
    std::fs::write(&scene, SCENE.replace("\"spp\": 4", "\"spp\": 200000")).unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let child = lobe()
        .args(["render", scene.to_str().unwrap(), "-o"])
        .arg(out.join("img.exr"))
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Interrupted once lobe handles SIGINT (installed before the scene loads), long before
    // 200,000 spp can end: no guessed delay.
    assert!(lobe_tests::wait_for_signal_handler(
        child.id(),
        libc::SIGINT
    ));
    sigint(&child);
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("interrupted"), "{err}");
    assert!(err.contains("Ctrl-C again to abort"), "{err}");
    assert!(listing(&out).is_empty(), "{:?}", listing(&out));
    // A batch fit: interrupt after the first report, then resume.
    let data = dir.path().join("data");
    std::fs::create_dir(&data).unwrap();
    for k in 0..6 {
        write_binned(
            serde_json::json!({"type": "ward", "diffuse": 0.1, "specular": 0.4, "alpha": 0.1 + 0.05 * k as f64}),
            (20, 45),
            &data.join(format!("m{k}.bin")),
        );
    }
    let reports = dir.path().join("reports");
    let args = [
        "fit",
        data.to_str().unwrap(),
        "-o",
        reports.to_str().unwrap(),
        "--models",
        "ward,he",
    ];
    let args = &args[..];
    let child = lobe()
        .args(args)
        .env("RAYON_NUM_THREADS", "1")
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while !reports.is_dir() || listing(&reports).iter().all(|f| !f.ends_with(".fit.json")) {
        assert!(t0.elapsed().as_secs() < 120, "no report appeared");
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    sigint(&child);
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{err}");
    assert!(err.contains("interrupted"), "{err}");
    assert!(
        err.contains("stopping the running fits now") && err.contains("Ctrl-C again to abort"),
        "{err}"
    );
    let kept = listing(&reports);
    assert!(!kept.is_empty() && kept.len() < 6, "{kept:?}");
    for f in &kept {
        assert!(f.ends_with(".fit.json"), "partial output left: {f}");
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(reports.join(f)).unwrap()).unwrap();
        assert!(v["models"]["he"]["error"].is_number(), "{f} is incomplete");
    }
    // The rerun resumes: the kept reports are untouched and the rest appear.
    let o = lobe().args(args).arg("-q").output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(listing(&reports).len(), 6);
}

#[test]
fn read_only_folders_and_full_disks_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.json");
    std::fs::write(&scene, SCENE).unwrap();
    // A read-only output folder (root ignores permissions: then the case is skipped).
    let ro = dir.path().join("ro");
    std::fs::create_dir(&ro).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
    if std::fs::write(ro.join("probe"), b"x").is_ok() {
        lobe_tests::skip_on_this_machine(
            "the read-only folder case: permissions are not enforced (running as root)",
        );
        std::fs::remove_file(ro.join("probe")).unwrap();
    } else {
        fails(
            &[
                "render",
                scene.to_str().unwrap(),
                "-o",
                ro.join("x.exr").to_str().unwrap(),
            ],
            "x.exr",
        );
        assert!(listing(&ro).is_empty());
    }
    // An unreadable input (skipped as root too).
    let secret = dir.path().join("secret.json");
    std::fs::write(&secret, SCENE).unwrap();
    std::fs::set_permissions(&secret, std::fs::Permissions::from_mode(0o000)).unwrap();
    if std::fs::read(&secret).is_err() {
        fails(&["render", secret.to_str().unwrap()], "secret.json");
    }
    // A full disk: a 64 KiB tmpfs, where mounting is allowed.
    let small = dir.path().join("small");
    std::fs::create_dir(&small).unwrap();
    let mounted = Command::new("mount")
        .args([
            "-t",
            "tmpfs",
            "-o",
            "size=64k",
            "tmpfs",
            small.to_str().unwrap(),
        ])
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !mounted {
        lobe_tests::skip_on_this_machine("the full-disk case: cannot mount a tmpfs here");
        return;
    }
    let big = SCENE.replace(
        "\"width\": 16, \"height\": 12",
        "\"width\": 256, \"height\": 256",
    );
    std::fs::write(&scene, big).unwrap();
    let out = small.join("big.exr");
    let o = lobe()
        .args([
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    let left = listing(&small);
    let _ = Command::new("umount").arg(&small).status();
    assert!(!o.status.success());
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("big.exr"), "{err}");
    assert!(
        left.is_empty(),
        "partial output left on the full disk: {left:?}"
    );
}

#[test]
fn an_output_that_is_an_input_is_refused_and_the_input_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("sub")).unwrap();
    write_binned(
        serde_json::from_str(WARD).unwrap(),
        (12, 24),
        &d.join("p.bin"),
    );
    let data = std::fs::read(d.join("p.bin")).unwrap();
    for out in ["p.bin", "./p.bin", "sub/../p.bin"] {
        refused_in(
            d,
            &["fit", "p.bin", "--models", "ward", "-o", out],
            &["would overwrite", "p.bin (the measured data)"],
        );
    }
    assert_eq!(std::fs::read(d.join("p.bin")).unwrap(), data);
    // A table read by the material, named directly or through a symlink.
    write_merl(&d.join("n.binary"));
    let merl = std::fs::read(d.join("n.binary")).unwrap();
    #[cfg(unix)]
    std::os::unix::fs::symlink(d.join("n.binary"), d.join("link.binary")).unwrap();
    for out in ["n.binary", "link.binary"] {
        let m = r#"{"type": "merl", "file": "n.binary"}"#;
        refused_in(
            d,
            &["tabulate", "--material", m, "-o", out],
            &["the table would overwrite", "n.binary"],
        );
    }
    assert!(std::fs::read(d.join("n.binary")).unwrap() == merl);
    // The heat map over the test image.
    write_exr(&d.join("t.exr"), (8, 8), 0.5);
    write_exr(&d.join("r.exr"), (8, 8), 0.4);
    let t = std::fs::read(d.join("t.exr")).unwrap();
    refused_in(
        d,
        &["compare", "t.exr", "r.exr", "--heatmap", "t.exr"],
        &["heat map would overwrite t.exr (the test image)"],
    );
    assert_eq!(std::fs::read(d.join("t.exr")).unwrap(), t);
    // Figures over their report.
    let o = lobe_in(
        d,
        &[
            "fit",
            "p.bin",
            "--models",
            "ward",
            "-o",
            "pw.fit.json",
            "-q",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report = std::fs::read(d.join("pw.fit.json")).unwrap();
    let m = r#"{"type": "binned", "file": "p.bin"}"#;
    refused_in(
        d,
        &[
            "figure",
            "polar",
            "--material",
            m,
            "--report",
            "pw.fit.json",
            "-o",
            "pw.fit.json",
        ],
        &["figure would overwrite pw.fit.json (the fit report)"],
    );
    refused_in(
        d,
        &["figure", "errors", ".", "-o", "pw.fit.json"],
        &["figure would overwrite", "pw.fit.json (a fit report)"],
    );
    assert_eq!(std::fs::read(d.join("pw.fit.json")).unwrap(), report);
    // Merged tables over a report.
    std::fs::write(d.join("t.md"), &report).unwrap();
    refused_in(
        d,
        &["fit", "merge", "t.md", "-o", "t"],
        &["Markdown table would overwrite t.md (a fit report)"],
    );
    assert_eq!(std::fs::read(d.join("t.md")).unwrap(), report);
}

#[test]
fn numeric_options_refuse_nan_and_infinity() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.json"), SCENE).unwrap();
    for args in [
        &["render", "s.json", "--exposure", "nan"][..],
        &["compare", "a.exr", "b.exr", "--exposure=-inf"],
        &[
            "tabulate",
            "--material",
            WARD,
            "--noise",
            "NaN",
            "-o",
            "t.binary",
        ],
        &["fit", "x.bin", "--resolution", "inf", "-o", "r.fit.json"],
    ] {
        let o = lobe_in(d, args);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?}");
        assert!(
            stderr.contains("expected a finite number"),
            "{args:?}: {stderr}"
        );
    }
    refused_in(
        d,
        &["eval", "--material", WARD, "--grid", "nan,0,0,0"],
        &["--grid: theta_i"],
    );
    assert_eq!(listing(d), ["s.json"]);
}

#[test]
fn json_mistakes_name_the_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("big.json"),
        SCENE.replace("\"fov\": 40", "\"fov\": 1e400"),
    )
    .unwrap();
    std::fs::write(
        d.join("nan.json"),
        SCENE.replace("\"fov\": 40", "\"fov\": NaN"),
    )
    .unwrap();
    for (f, token) in [("big.json", "1e400"), ("nan.json", "NaN")] {
        refused_in(
            d,
            &["render", f],
            &[
                &format!("{f}: line 2, column"),
                token,
                "JSON numbers must be finite",
            ],
        );
    }
    refused_in(
        d,
        &[
            "eval",
            "--material",
            r#"{"type": "ward", "alpha": NaN}"#,
            "--grid",
            "0,0,0,0",
        ],
        &["--material: line 1, column", "must be finite"],
    );
    let dup = SCENE.replacen(
        "{",
        r#"{"materials": {"m": {"type": "lambert"}, "m": {"type": "ward"}},"#,
        1,
    );
    std::fs::write(d.join("dup.json"), dup).unwrap();
    refused_in(
        d,
        &["render", "dup.json"],
        &["dup.json", "materials.m", "given twice"],
    );
    assert_eq!(listing(d), ["big.json", "dup.json", "nan.json"]);
}

#[test]
fn help_texts_name_real_files_and_every_output() {
    let help = |args: &[&str]| {
        let o = lobe().args(args).arg("--help").output().unwrap();
        assert!(o.status.success());
        String::from_utf8_lossy(&o.stdout).to_string()
    };
    let render = help(&["render"]);
    assert!(
        render.contains("out/showcase.exr, .png, .stats.json"),
        "{render}"
    );
    assert!(!render.contains("showcase.{exr,png,json}"));
    let compare = help(&["compare"]);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut named = 0;
    for word in compare.split_whitespace() {
        if word.starts_with("reference-images/") {
            assert!(root.join(word).exists(), "compare --help names {word}");
            named += 1;
        }
    }
    assert!(named >= 2, "{compare}");
    for fig in ["errors", "multilobe", "polar", "spheres", "lobes"] {
        let h = help(&["figure", fig]);
        let line = h
            .lines()
            .find(|l| l.trim_start().starts_with("-o, --output"))
            .unwrap();
        assert!(line.contains("Output PNG file"), "figure {fig}: {line}");
    }
}

/// A second Ctrl-C exits at once, even while the first waits for work that cannot stop
/// (reading and binning a MERL table, about half a second). The first Ctrl-C is sent
/// once the batch says it reads the table: sent earlier, the batch would stop before
/// reading and exit before the second one.
#[test]
fn a_second_ctrl_c_exits_at_once() {
    use std::io::BufRead;
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    std::fs::create_dir(&data).unwrap();
    write_merl(&data.join("m.binary"));
    let reports = dir.path().join("reports");
    let mut child = lobe()
        .args([
            "fit",
            data.to_str().unwrap(),
            "-o",
            reports.to_str().unwrap(),
        ])
        .args(["--models", "he"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = std::io::BufReader::new(child.stderr.take().unwrap());
    let mut err = String::new();
    while !err.contains("m: reading the data") {
        let n = stderr.read_line(&mut err).unwrap();
        assert!(n > 0, "the batch ended before reading its data: {err}");
    }
    sigint(&child);
    while !err.contains("Ctrl-C again to abort") {
        let n = stderr.read_line(&mut err).unwrap();
        assert!(n > 0, "the first Ctrl-C was not acknowledged: {err}");
    }
    sigint(&child);
    let status = child.wait().unwrap();
    std::io::Read::read_to_string(&mut stderr, &mut err).unwrap();
    assert_eq!(status.code(), Some(130), "{err}");
    assert!(
        err.contains("Ctrl-C again to abort") && err.contains("lobe: aborted"),
        "{err}"
    );
    assert!(listing(&reports).is_empty(), "{:?}", listing(&reports));
}

/// The README's "Other commands" are consistent as written, without running them (together
/// they take minutes): the binary is installed first (the text says how), every output
/// goes under out/, and every file a command reads is in the repository, in
/// ../shared/data, or written by an earlier line.
#[test]
fn readme_commands_read_existing_files_and_write_under_out() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let section = readme
        .split("## Other commands")
        .nth(1)
        .and_then(|s| s.split("\n## ").next())
        .expect("an Other commands section");
    assert!(
        section.contains("cargo install --path tools/cli"),
        "{section}"
    );
    let block = section.split("```").nth(1).expect("a code block");
    let mut written: Vec<String> = Vec::new();
    for line in block.lines().map(str::trim).filter(|l| !l.is_empty()) {
        let cmd = line.split("  #").next().unwrap().trim();
        let words: Vec<&str> = cmd.split_whitespace().collect();
        let first = words.iter().position(|w| *w == "lobe").unwrap_or(0);
        let known = ["lobe", "mkdir", "tools/mitsuba/bench.sh", "scripts/fuzz.sh"];
        assert!(known.contains(&words[first]), "{line}");
        if words[first] != "lobe" {
            continue;
        }
        // Outputs: after -o and --heatmap, all under out/.
        let mut outputs = Vec::new();
        for w in words.windows(2) {
            if ["-o", "--heatmap"].contains(&w[0]) {
                assert!(w[1].starts_with("out/"), "{line}: writes {}", w[1]);
                outputs.push(w[1].trim_end_matches('/').to_string());
            }
        }
        // Inputs: path-like words and the "file" of JSON descriptions.
        let mut inputs: Vec<String> = words
            .windows(2)
            .filter(|w| !["-o", "--heatmap"].contains(&w[0]))
            .map(|w| w[1].trim_matches(['\'', '"', ',', '}']).to_string())
            .filter(|w| w.contains('/') && !w.starts_with("docs/") && !w.contains(".."))
            .chain(
                cmd.split("\"file\": \"")
                    .skip(1)
                    .map(|s| s.split('"').next().unwrap().to_string()),
            )
            .collect();
        inputs.extend(
            words
                .iter()
                .filter(|w| w.starts_with("../shared/data"))
                .map(|w| w.to_string()),
        );
        for i in inputs {
            let shared = i.starts_with("../shared/data");
            let made = written
                .iter()
                .any(|o| i == *o || i.starts_with(&format!("{o}/")));
            assert!(
                made || shared || root.join(&i).exists(),
                "{line}: reads {i}, which is neither in the repository nor written before"
            );
            if shared && shared_data().is_some() {
                assert!(
                    root.join(&i).exists(),
                    "{line}: {i} is not in ../shared/data"
                );
            }
        }
        written.extend(outputs);
    }
    assert!(written.len() >= 10, "{written:?}");
}

/// Output piped into a reader that has gone (`lobe models | head -1`) ends the process
/// quietly, as Unix tools end (by SIGPIPE), instead of with a panic in `println!`.
#[cfg(unix)]
#[test]
fn a_closed_stdout_ends_the_process_without_a_panic() {
    use std::os::fd::{FromRawFd, OwnedFd};
    use std::os::unix::process::ExitStatusExt;
    use std::process::Stdio;
    // A pipe whose reading end is closed before the process starts: every write fails,
    // however fast the process is (closing it after the spawn raced with the writes).
    let mut fds = [0; 2];
    // SAFETY: pipe(2) fills the two descriptors it is given.
    assert_eq!(unsafe { libc::pipe(fds.as_mut_ptr()) }, 0);
    // SAFETY: both descriptors were just created and are owned here alone.
    let (read_end, write_end) =
        unsafe { (OwnedFd::from_raw_fd(fds[0]), OwnedFd::from_raw_fd(fds[1])) };
    drop(read_end);
    let child = lobe()
        .arg("models")
        .stdout(Stdio::from(write_end))
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(
        out.status.signal(),
        Some(libc::SIGPIPE),
        "{:?}: {err}",
        out.status
    );
}
