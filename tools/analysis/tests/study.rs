//! The study (lobe_analysis::study) on two built-in analytic materials, quick settings and
//! one environment map: an interrupted study resumes and gives the same report as an
//! uninterrupted one; the report's pages are well formed, every link and image resolves
//! and every material has its page; in headless Chromium (Debian's `chromium`, skipped
//! with a message when absent) the index logs no console message and its table sorts.

use lobe_analysis::study::{self, StudyConfig, StudyMaterial, StudyProgress, StudySummary};
use lobe_materials::registry::Registry;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::LazyLock;
use std::sync::atomic::{AtomicUsize, Ordering};

fn materials() -> Vec<StudyMaterial> {
    study::analytic_materials()
        .into_iter()
        .filter(|m| m.name == "builtin-red-plastic" || m.name == "builtin-rough-clay")
        .collect()
}

fn config(out: &Path) -> StudyConfig {
    StudyConfig {
        inputs: Vec::new(),
        out: out.to_path_buf(),
        quick: true,
        shard: (0, 1),
        envs: vec!["builtin:studio".into()],
        error_spp: None,
    }
}

/// Counts finished steps.
#[derive(Default)]
struct Count(AtomicUsize);

impl StudyProgress for Count {
    fn finished(&self, _what: &str) {
        self.0.fetch_add(1, Ordering::SeqCst);
    }
}

fn run(
    out: &Path,
    stop: &(dyn Fn() -> bool + Sync),
    count: &Count,
) -> Result<StudySummary, String> {
    study::run_materials(
        &Registry::builtin(),
        &config(out),
        &materials(),
        stop,
        count,
    )
    .map_err(|e| e.to_string())
}

/// One uninterrupted study, shared by the tests.
static STUDY: LazyLock<tempfile::TempDir> = LazyLock::new(|| {
    let dir = tempfile::tempdir().unwrap();
    let s = run(dir.path(), &|| false, &Count::default()).unwrap();
    assert_eq!((s.materials, s.skipped, s.pending), (2, 0, 0));
    assert_eq!(
        s.index.as_deref(),
        Some(dir.path().join("index.html").as_path())
    );
    dir
});

/// Every file under `root`, by relative path.
fn files(root: &Path) -> BTreeMap<String, PathBuf> {
    let mut out = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p
                    .strip_prefix(root)
                    .unwrap()
                    .to_string_lossy()
                    .replace('\\', "/");
                out.insert(rel, p);
            }
        }
    }
    out
}

/// The text with the attributes and content of every element marked `class="timed"`
/// (values measured from timings) blanked.
fn untimed(html: &str) -> String {
    const TIMED: &str = "class=\"timed\"";
    let mut out = String::new();
    let mut rest = html;
    while let Some(k) = rest.find(TIMED) {
        let open_end = k + TIMED.len();
        out += &rest[..open_end];
        let close = open_end + rest[open_end..].find("</").unwrap();
        rest = &rest[close..];
    }
    out + rest
}

/// A fit report without its timings (fit seconds, the costs measured beside the
/// selection); the selected model stays: it ranks by the committed cost table.
fn untimed_report(p: &Path) -> serde_json::Value {
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap();
    let selected = v["selected"]["model"].clone();
    assert!(selected.is_string(), "{p:?} selects no model");
    v["selected"] = selected;
    for m in v["models"].as_object_mut().unwrap().values_mut() {
        m.as_object_mut().unwrap().remove("seconds");
    }
    v
}

/// The metrics of a render step, or results.json, without the timed values (the
/// equal-time errors and the speed/accuracy curves).
fn untimed_metrics(p: &Path) -> serde_json::Value {
    fn strip(v: &mut serde_json::Value) {
        if let Some(o) = v.as_object_mut() {
            for k in ["equal_time", "curve", "equal_time_budget"] {
                o.remove(k);
            }
            o.values_mut().for_each(strip);
        } else if let Some(a) = v.as_array_mut() {
            a.iter_mut().for_each(strip);
        }
    }
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap();
    strip(&mut v);
    v
}

#[test]
fn an_interrupted_study_resumes_to_the_same_report() {
    let whole = STUDY.path();
    let dir = tempfile::tempdir().unwrap();
    // Stop once three steps are done (in the middle of the first material's renders).
    let count = Count::default();
    let stop = || count.0.load(Ordering::SeqCst) >= 3;
    let e = run(dir.path(), &stop, &count).unwrap_err();
    assert!(e.contains("interrupted"), "{e}");
    let partial = files(dir.path());
    assert!(
        !partial.contains_key("index.html"),
        "no report before every step is done"
    );
    assert!(partial.keys().all(|f| !f.ends_with(".tmp")), "{partial:?}");
    // The rerun keeps what was done and computes the rest.
    let s = run(dir.path(), &|| false, &Count::default()).unwrap();
    assert!(s.skipped >= 2 && s.computed >= 1, "{s:?}");
    let (a, b) = (files(whole), files(dir.path()));
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    for (rel, pa) in &a {
        let pb = &b[rel];
        let what = format!("{rel} differs between the resumed and the uninterrupted study");
        if rel.ends_with(".html") || rel.ends_with(".md") || rel.ends_with(".csv") {
            let (x, y) = (
                std::fs::read_to_string(pa).unwrap(),
                std::fs::read_to_string(pb).unwrap(),
            );
            if rel.ends_with(".html") {
                assert_eq!(untimed(&x), untimed(&y), "{what}");
            } else {
                // The trade-off tables: material, representation, Eq. (1) error, RMSE, its
                // interval and FLIP are not timed (Markdown lines start with an empty cell).
                let n = 7;
                let cut = |t: &str| -> Vec<String> {
                    t.lines()
                        .map(|l| l.split([',', '|']).take(n).collect::<Vec<_>>().join(","))
                        .collect()
                };
                assert_eq!(cut(&x), cut(&y), "{what}");
            }
        } else if rel.ends_with(".fit.json") {
            assert_eq!(untimed_report(pa), untimed_report(pb), "{what}");
        } else if rel.ends_with("metrics.json") || rel == "results.json" {
            assert_eq!(untimed_metrics(pa), untimed_metrics(pb), "{what}");
        } else if rel.starts_with("microfacet/") && rel.ends_with(".json") {
            let r = |p: &Path| -> serde_json::Value {
                let v: serde_json::Value =
                    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap();
                serde_json::json!([v["error"], v["material"]])
            };
            assert_eq!(r(pa), r(pb), "{what}");
        } else {
            // Images, tables of p and figures: byte for byte.
            assert!(
                std::fs::read(pa).unwrap() == std::fs::read(pb).unwrap(),
                "{what}"
            );
        }
    }
}

/// Percent-decodes a relative URL.
fn decode(u: &str) -> String {
    let b = u.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            out.push(u8::from_str_radix(&u[i + 1..i + 3], 16).unwrap());
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).unwrap()
}

/// The values of every `attr="..."` in the page.
fn attrs<'a>(html: &'a str, attr: &str) -> Vec<&'a str> {
    let key = format!(" {attr}=\"");
    html.match_indices(&key)
        .map(|(k, _)| {
            let s = &html[k + key.len()..];
            &s[..s.find('"').unwrap()]
        })
        .collect()
}

/// Checks that every non-void element of the page is closed as often as it is opened.
fn assert_balanced(html: &str, page: &str) {
    for tag in [
        "html",
        "head",
        "body",
        "table",
        "thead",
        "tbody",
        "tr",
        "td",
        "th",
        "figure",
        "figcaption",
        "a",
        "div",
        "p",
        "h1",
        "h2",
        "h3",
        "pre",
        "code",
        "script",
        "style",
        "title",
        "span",
        "b",
        "i",
    ] {
        let opens =
            html.matches(&format!("<{tag}>")).count() + html.matches(&format!("<{tag} ")).count();
        let closes = html.matches(&format!("</{tag}>")).count();
        assert_eq!(
            opens, closes,
            "{page}: <{tag}> opened {opens} times, closed {closes}"
        );
    }
}

#[test]
fn every_link_and_image_of_the_report_resolves_and_every_material_has_a_page() {
    let root = STUDY.path();
    let all = files(root);
    let pages: Vec<&String> = all.keys().filter(|f| f.ends_with(".html")).collect();
    for m in materials() {
        let page = format!("materials/{}.html", m.name);
        assert!(all.contains_key(&page), "no page for {}", m.name);
        let index = std::fs::read_to_string(root.join("index.html")).unwrap();
        assert!(
            index.contains(&format!("href=\"{page}\"")),
            "index does not link {page}"
        );
    }
    assert_eq!(pages.len(), 1 + materials().len());
    let mut checked = 0;
    for rel in pages {
        let html = std::fs::read_to_string(&all[rel]).unwrap();
        assert!(html.starts_with("<!DOCTYPE html>"), "{rel}");
        assert_balanced(&html, rel);
        let dir = Path::new(rel).parent().unwrap_or(Path::new(""));
        for u in attrs(&html, "href").into_iter().chain(attrs(&html, "src")) {
            assert!(
                !u.contains("://") && !u.starts_with("//"),
                "{rel}: {u} is not local"
            );
            let target = root.join(dir).join(decode(u));
            assert!(target.is_file(), "{rel}: {u} does not resolve");
            checked += 1;
        }
    }
    assert!(checked > 40, "{checked} links");
}

#[test]
fn results_json_holds_every_error_with_its_interval_and_the_pages_show_it() {
    let root = STUDY.path();
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(root.join("results.json")).unwrap()).unwrap();
    assert_eq!(v["format_version"], 1);
    for m in materials() {
        let entry = &v["materials"][&m.name];
        let report: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(root.join(format!("fits/{}.fit.json", m.name))).unwrap(),
        )
        .unwrap();
        assert_eq!(entry["selected"], report["selected"]["model"], "{}", m.name);
        let map = &entry["maps"]["studio"];
        assert!(map["noise_floor"].as_f64().unwrap() >= 0.0, "{map}");
        let errors = map["errors"].as_object().unwrap();
        assert!(errors.contains_key("measured"), "{map}");
        for label in report["models"].as_object().unwrap().keys() {
            assert!(errors.contains_key(label), "{}: no {label}", m.name);
        }
        let page =
            std::fs::read_to_string(root.join(format!("materials/{}.html", m.name))).unwrap();
        for (rep, e) in errors {
            let (rmse, lo, hi) = (
                e["rmse"].as_f64().unwrap(),
                e["ci95"][0].as_f64().unwrap(),
                e["ci95"][1].as_f64().unwrap(),
            );
            assert!(lo <= rmse && rmse <= hi, "{}: {rep}: {e}", m.name);
            assert!(e["flip"].as_f64().unwrap() >= 0.0, "{rep}: {e}");
            // The page shows the number results.json holds, with its interval.
            assert!(
                page.contains(&format!("data-v=\"{rmse:e}\"")),
                "{rep}: {rmse}"
            );
            assert!(page.contains(&format!("[{lo:.3e}, {hi:.3e}]")), "{rep}");
        }
    }
}

/// Chromium, if installed.
fn chromium() -> Option<PathBuf> {
    ["chromium", "chromium-browser"].iter().find_map(|c| {
        let out = Command::new("sh")
            .args(["-c", &format!("command -v {c}")])
            .output()
            .ok()?;
        let p = String::from_utf8_lossy(&out.stdout).trim().to_string();
        (out.status.success() && !p.is_empty()).then(|| PathBuf::from(p))
    })
}

/// Loads `url` in headless Chromium: the DOM after the scripts ran, and the console
/// messages the page logged.
fn load(chromium: &Path, url: &str) -> (String, Vec<String>) {
    let profile = tempfile::tempdir().unwrap();
    let out = Command::new(chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--enable-logging=stderr",
            "--v=0",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .args(["--dump-dom", url])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "chromium failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let console = String::from_utf8_lossy(&out.stderr)
        .lines()
        .filter(|l| l.contains(":CONSOLE"))
        .map(str::to_string)
        .collect();
    (String::from_utf8_lossy(&out.stdout).into_owned(), console)
}

/// The data-v values of column `col` of the first table's body, in row order.
fn column(dom: &str, col: usize) -> Vec<f64> {
    let body = &dom[dom.find("<tbody>").unwrap()..dom.find("</tbody>").unwrap()];
    body.split("<tr>")
        .skip(1)
        .map(|row| {
            let cell = row.split("<td").nth(col + 1).unwrap();
            attrs(&format!(" {cell}"), "data-v")
                .first()
                .map_or(f64::NAN, |v| v.parse().unwrap())
        })
        .collect()
}

#[test]
fn the_index_sorts_in_headless_chromium_without_console_messages() {
    let Some(chromium) = chromium() else {
        lobe_tests::skip_on_this_machine(
            "the report in headless chromium: chromium is not installed (Debian: apt-get install chromium; .ci/run installs it)",
        );
        return;
    };
    // The harness sees console messages: a page that logs one is caught.
    let probe = tempfile::tempdir().unwrap();
    let bad = probe.path().join("bad.html");
    std::fs::write(
        &bad,
        "<!DOCTYPE html><script>console.error('probe')</script>",
    )
    .unwrap();
    let (_, console) = load(&chromium, &format!("file://{}", bad.display()));
    assert!(console.iter().any(|l| l.contains("probe")), "{console:?}");
    let index = STUDY.path().join("index.html");
    let url = format!("file://{}", index.display());
    let (dom, console) = load(&chromium, &url);
    assert!(console.is_empty(), "console messages: {console:?}");
    // A numeric column whose rows (in material name order) are not sorted: #sort=K sorts
    // it ascending, #sort=K- descending.
    let ncols = dom[dom.find("<thead>").unwrap()..dom.find("</thead>").unwrap()]
        .matches("<th")
        .count();
    let sorted = |v: &[f64], dir: f64| v.windows(2).all(|p| dir * (p[1] - p[0]) >= 0.0);
    let col = (2..ncols)
        .find(|&c| {
            let v = column(&dom, c);
            v.iter().all(|x| x.is_finite()) && !sorted(&v, 1.0)
        })
        .expect("a numeric column not already in ascending order");
    for (hash, dir) in [
        (format!("#sort={col}"), 1.0),
        (format!("#sort={col}-"), -1.0),
    ] {
        let (dom, console) = load(&chromium, &format!("{url}{hash}"));
        assert!(console.is_empty(), "{hash}: console messages: {console:?}");
        let v = column(&dom, col);
        assert!(sorted(&v, dir), "{hash}: column {col} not sorted: {v:?}");
    }
}

/// Anisotropic binned data (4D, coarse bins of a brushed anisotropic Ward) gets the
/// anisotropic models too, and the whole study runs on it.
#[test]
fn a_study_of_anisotropic_data_fits_the_anisotropic_models() {
    use lobe_materials::measured::binned::{Axis, Binned};
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("brushed.bin");
    let m = Registry::builtin()
        .create(
            &serde_json::json!({"type": "ward-anisotropic", "diffuse": 0.1, "specular": 0.3, "alpha_x": 0.08, "alpha_y": 0.3}),
            "m",
        )
        .unwrap();
    let (theta, phi) = (Axis::new(10, 0.0, 90.0), Axis::new(20, 0.0, 360.0));
    let mut t = Binned::empty(true, vec![theta, theta, phi, phi]);
    t.values = (0..t.len())
        .map(|k| t.directions(k))
        .map(|(wi, wo)| Some(m.eval(wo, wi).to_array()))
        .collect();
    t.write(&data).unwrap();
    let out = dir.path().join("study");
    let mut config = config(&out);
    config.inputs = vec![data];
    let s = study::run(&Registry::builtin(), &config, &|| false, &Count::default()).unwrap();
    assert!(s.index.is_some());
    let report = lobe_materials::fit::report::read(&out.join("fits/brushed.fit.json")).unwrap();
    assert!(
        report.models.contains_key("ward-anisotropic"),
        "{:?}",
        report.models.keys()
    );
    assert!(
        report.models["ward-anisotropic"].error_normalized < report.models["ward"].error_normalized
    );
}

/// Writes coarse isotropic binned data of `material` to `path`.
fn write_isotropic(material: serde_json::Value, path: &Path) {
    use lobe_materials::measured::binned::{Axis, Binned};
    let m = Registry::builtin().create(&material, "m").unwrap();
    let theta = Axis::new(12, 0.0, 80.0);
    let mut t = Binned::empty(false, vec![theta, theta, Axis::new(24, 0.0, 180.0)]);
    t.values = (0..t.len())
        .map(|k| t.directions(k))
        .map(|(wi, wo)| Some(m.eval(wo, wi).to_array()))
        .collect();
    t.write(path).unwrap();
}

/// Steps are keyed by content: replacing the data file redoes every step of its material
/// (before keys: "0 steps computed" and the old material's report), and a map file named
/// like the built-in one (`--env .../studio.exr` after `builtin:studio`) redoes the renders
/// only. Each output records its key.
#[test]
fn a_study_redoes_what_its_data_or_map_changed() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("paint.bin");
    let ward = |alpha: f64| serde_json::json!({"type": "ward", "diffuse": 0.2, "specular": 0.1, "alpha": alpha});
    write_isotropic(ward(0.1), &data);
    let out = dir.path().join("study");
    let mut config = config(&out);
    config.inputs = vec![data.clone()];
    let go = |c: &StudyConfig| {
        study::run(&Registry::builtin(), c, &|| false, &Count::default()).unwrap()
    };
    let first = go(&config);
    assert_eq!((first.computed, first.skipped), (4, 0), "{first:?}");
    let same = go(&config);
    assert_eq!((same.computed, same.skipped), (0, 4), "{same:?}");
    let alpha = || {
        let r = lobe_materials::fit::report::read(&out.join("fits/paint.fit.json")).unwrap();
        assert!(r.key.is_some());
        r.models["ward"].material["alpha"].as_f64().unwrap()
    };
    assert!((alpha() - 0.1).abs() < 0.01, "{}", alpha());
    let metrics = out.join("renders/paint/studio/metrics.json");
    let key_of = |p: &Path| -> String {
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap();
        v["key"].as_str().unwrap().to_string()
    };
    let render_key = key_of(&metrics);
    // Other data under the same name: everything is redone.
    write_isotropic(ward(0.3), &data);
    let changed = go(&config);
    assert_eq!((changed.computed, changed.skipped), (4, 0), "{changed:?}");
    assert!((alpha() - 0.3).abs() < 0.03, "{}", alpha());
    assert_ne!(key_of(&metrics), render_key);
    // A map file named studio: only the renders under it are redone.
    let studio = dir.path().join("maps/studio.exr");
    std::fs::create_dir_all(studio.parent().unwrap()).unwrap();
    let px = vec![lobe_renderer::Rgb::splat(0.5); 32 * 16];
    lobe_renderer::image_io::write_exr(&studio, 32, 16, &px).unwrap();
    config.envs = vec![studio.display().to_string()];
    let mapped = go(&config);
    assert_eq!((mapped.computed, mapped.skipped), (1, 3), "{mapped:?}");
}

/// `--error-spp`: the estimate's budget is the user's (its pilot no larger), recorded in
/// study.json and bounding every map's mean; one under the estimate's smallest pixel
/// count or over its largest is refused with a message before anything is written, and
/// another budget in a folder made with one is refused too.
#[test]
fn the_image_error_budget_is_the_users_and_is_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = config(&dir.path().join("study"));
    let one = &materials()[..1];
    let go = |c: &StudyConfig| {
        study::run_materials(&Registry::builtin(), c, one, &|| false, &Count::default())
            .map_err(|e| e.to_string())
    };
    for n in [16, 1 << 20] {
        c.error_spp = Some(n);
        let e = go(&c).unwrap_err();
        let expected =
            format!("--error-spp: expected a mean of 32 to 16384 samples per pixel, found {n}");
        assert_eq!(e, expected);
        assert!(
            !c.out.exists(),
            "--error-spp {n}: the study folder was made"
        );
    }
    c.error_spp = Some(48);
    let s = study::Settings::of(&c);
    assert_eq!((s.error_pilot_spp, s.error_max_spp), (32, 48));
    go(&c).unwrap();
    let read = |p: PathBuf| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let recorded = read(c.out.join("study.json"));
    assert_eq!(recorded["settings"]["error_max_spp"], 48);
    let metrics = read(
        c.out
            .join(format!("renders/{}/studio/metrics.json", one[0].name)),
    );
    let spp = metrics["spp"].as_u64().unwrap();
    assert!((32..=48).contains(&spp), "mean spp {spp}");
    c.error_spp = Some(64);
    let e = go(&c).unwrap_err();
    assert!(
        e.contains("study.json") && e.contains("other settings"),
        "{e}"
    );
}
