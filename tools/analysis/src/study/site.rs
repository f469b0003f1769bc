//! The report of a study as a static site that works offline from its folder (no CDN, no
//! server), like the website of Ngan et al. 2005's study: DIR/index.html with a sortable
//! table of every material's errors per model, the selected model and the costs, the
//! trade-off table and Figures 14 and 5; DIR/materials/NAME.html per material with its
//! sphere images side by side (the measured data as reference, each representation with
//! its FLIP heat map and colour bar), parameters, errors with their intervals, rankings
//! that claim an order only where intervals separate, and plots. The image errors are read
//! from DIR/results.json, written first. Also DIR/tradeoff.md and .csv.
//!
//! Values that come from a timing (costs, render seconds, equal-time errors) are marked
//! `class="timed"`: they vary from run to run. Everything else is a function of the data
//! and the settings, the selection included (it ranks by the committed cost table,
//! [`crate::cost::reference_cost`]).

use super::StudyMaterial;
use super::steps::{Context, Layout, headline_fits, representations};
use crate::figures;
use lobe_materials::fit::report::{self, FitReport};
use lobe_renderer::Error;
use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Everything the pages show of one material.
struct MaterialData {
    name: String,
    source: String,
    report: FitReport,
    /// The microfacet estimate's JSON (error, material, costs).
    microfacet: Value,
    /// Per environment map its entry of results.json.
    maps: Vec<(String, Value)>,
    /// The representations' names, the measured data first.
    reps: Vec<String>,
}

/// Escapes text for HTML.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A relative URL of a path: every byte but letters, digits and `-._/` percent-encoded.
pub fn url(path: &str) -> String {
    path.bytes()
        .map(|b| match b {
            b'a'..=b'z' | b'A'..=b'Z' | b'0'..=b'9' | b'-' | b'.' | b'_' | b'/' => {
                (b as char).to_string()
            }
            _ => format!("%{b:02X}"),
        })
        .collect()
}

/// The class attribute of a cell whose value comes from a timing (none otherwise).
fn timed_class(timed: bool) -> &'static str {
    if timed { " class=\"timed\"" } else { "" }
}

/// A number cell: scientific notation to 3 significant digits, the full value for
/// sorting; empty when not finite. `timed` marks values that come from timings.
fn num(x: Option<f64>, timed: bool) -> String {
    let class = timed_class(timed);
    match x.filter(|x| x.is_finite()) {
        Some(x) => format!("<td{class} data-v=\"{x:e}\">{x:.2e}</td>"),
        None => format!("<td{class}></td>"),
    }
}

/// A number in plain notation to 3 significant digits, trailing zeros dropped (counts,
/// times): 32, 75.4, 0.453.
pub fn plain(x: f64) -> String {
    let digits = match x.abs() {
        a if a >= 100.0 || a == 0.0 => 0,
        a if a >= 10.0 => 1,
        a if a >= 1.0 => 2,
        a => (2 - a.log10().floor() as i32).clamp(0, 12) as usize,
    };
    let s = format!("{x:.digits$}");
    match s.contains('.') {
        true => s.trim_end_matches('0').trim_end_matches('.').to_string(),
        false => s,
    }
}

/// A cell in plain notation ([`plain`]) with a unit.
fn plain_cell(x: Option<f64>, unit: &str, timed: bool) -> String {
    let class = timed_class(timed);
    match x.filter(|x| x.is_finite()) {
        Some(x) => format!("<td{class} data-v=\"{x:e}\">{}{unit}</td>", plain(x)),
        None => format!("<td{class}></td>"),
    }
}

/// A table in a container that scrolls sideways when the table is wider than the page.
fn scroll(table: &str) -> String {
    format!("<div class=\"scroll\">\n{table}</div>\n")
}

const STYLE: &str = "body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,'DejaVu Sans',sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222;line-height:1.45}
h1{font-weight:600}h2{margin-top:2em;border-bottom:1px solid #ddd}
table{border-collapse:collapse;font-size:0.9em;margin:1em 0}
th,td{padding:0.25em 0.6em;border-bottom:1px solid #eee;text-align:right;white-space:nowrap}
.scroll{overflow-x:auto;max-width:100%}
td.best{font-weight:600;background:#e6f2e6}
table.params{font-size:0.85em;margin:0}table.params td{border:0;padding:0 0.4em}
th:first-child,td:first-child{text-align:left}
table.sortable th{cursor:pointer;user-select:none;background:#f6f6f6}
th[aria-sort=ascending]::after{content:' \\25B2'}th[aria-sort=descending]::after{content:' \\25BC'}
td.timed{color:#555;font-style:italic}
.grid{display:flex;flex-wrap:wrap;gap:0.8em}
figure{margin:0;text-align:center;font-size:0.85em}
img.render{width:256px;height:256px;border:1px solid #ccc}
.bar{display:flex;align-items:center;gap:0.5em;font-size:0.85em;margin:0.5em 0}.bar .scale{display:inline-block;width:256px;height:12px;border:1px solid #ccc}
img.plot{max-width:100%;border:1px solid #eee}
code,pre{font-size:0.85em;background:#f6f6f6}
pre{padding:0.4em;white-space:pre-wrap;word-break:break-all;max-width:40em;text-align:left;margin:0}
.note{color:#555;font-size:0.9em}";

/// The table sorter: a click on a header sorts its table by that column (numbers by
/// their data-v value, text case-insensitively; again: the other way). `#sort=K` (or
/// `#sort=K-`, descending) in the URL sorts the first table by column K on load.
const SORTER: &str = "(function(){
function key(td){var v=td.getAttribute('data-v');if(v!==null){var x=parseFloat(v);if(!isNaN(x))return x;}return td.textContent.trim().toLowerCase();}
function sortBy(t,col,dir){var b=t.tBodies[0];var rows=Array.prototype.slice.call(b.rows);
rows.sort(function(p,q){var x=key(p.cells[col]),y=key(q.cells[col]);var xn=typeof x==='number',yn=typeof y==='number';
if(xn&&yn)return dir*(x-y);if(xn)return -1;if(yn)return 1;return dir*(x<y?-1:(x>y?1:0));});
rows.forEach(function(r){b.appendChild(r);});
Array.prototype.forEach.call(t.tHead.rows[0].cells,function(th,i){th.setAttribute('aria-sort',i===col?(dir>0?'ascending':'descending'):'none');});}
Array.prototype.forEach.call(document.querySelectorAll('table.sortable'),function(t){
Array.prototype.forEach.call(t.tHead.rows[0].cells,function(th,i){th.addEventListener('click',function(){sortBy(t,i,th.getAttribute('aria-sort')==='ascending'?-1:1);});});});
var m=/sort=(\\d+)(-?)/.exec(location.hash);var t=document.querySelector('table.sortable');
if(m&&t&&+m[1]<t.tHead.rows[0].cells.length)sortBy(t,+m[1],m[2]?-1:1);
})();";

/// A page: title, style, body and the sorter.
fn page(title: &str, body: &str) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<title>{}</title>\n<style>\n{STYLE}\n</style>\n</head>\n<body>\n{body}<script>\n{SORTER}\n</script>\n</body>\n</html>\n",
        esc(title)
    )
}

/// An image linked to its full-size file (and an SVG of a chart beside it).
fn plot(src: &str, alt: &str, svg: bool) -> String {
    let mut s = format!(
        "<figure><a href=\"{u}\"><img class=\"plot\" src=\"{u}\" alt=\"{a}\" loading=\"lazy\"></a>",
        u = url(src),
        a = esc(alt)
    );
    if svg {
        let svg_src = src.replace(".png", ".svg");
        let _ = write!(
            s,
            "<figcaption><a href=\"{}\">SVG</a></figcaption>",
            url(&svg_src)
        );
    }
    s + "</figure>\n"
}

/// A material description for reading: numbers to 4 significant digits, keys in order.
fn short_json(v: &Value) -> String {
    match v {
        Value::Number(n) => match n.as_f64() {
            Some(x) if n.is_f64() => format!("{}", format!("{x:.4e}").parse::<f64>().unwrap_or(x)),
            _ => n.to_string(),
        },
        Value::Array(a) => format!(
            "[{}]",
            a.iter().map(short_json).collect::<Vec<_>>().join(", ")
        ),
        Value::Object(o) => format!(
            "{{{}}}",
            o.iter()
                .map(|(k, x)| format!("\"{k}\": {}", short_json(x)))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        other => other.to_string(),
    }
}

/// A material description as a small table: one row per parameter (numbers as
/// [`short_json`] writes them, colours as triples, names without quotes), a composite's
/// lobes as nested rows.
fn params_table(v: &Value) -> String {
    let Some(o) = v.as_object() else {
        return format!("<pre>{}</pre>", esc(&short_json(v)));
    };
    let mut s = String::from("<table class=\"params\">");
    for (k, x) in o {
        let cell = match (k.as_str(), x) {
            ("lobes", Value::Array(lobes)) => lobes
                .iter()
                .enumerate()
                .map(|(i, l)| format!("lobe {}: {}", i + 1, params_table(l)))
                .collect::<Vec<_>>()
                .join(""),
            (_, Value::String(text)) => esc(text),
            _ => esc(&short_json(x)),
        };
        let _ = write!(s, "<tr><td>{}</td><td>{cell}</td></tr>", esc(k));
    }
    s + "</table>"
}

/// Reads what the pages show of each material; its image errors come from `results`
/// (results.json as written).
fn gather(
    ctx: &Context<'_>,
    mats: &[StudyMaterial],
    results: &Value,
) -> Result<Vec<MaterialData>, Error> {
    let l = ctx.layout;
    mats.iter()
        .map(|m| {
            let report = report::read(&l.fit(&m.name))?;
            let microfacet = lobe_materials::json::read(&l.microfacet(&m.name, "json"))?;
            let maps = ctx
                .envs
                .iter()
                .map(|e| {
                    let v = &results["materials"][&m.name]["maps"][&e.name];
                    (e.name.clone(), v.clone())
                })
                .collect();
            let reps = representations(ctx, m)?.into_iter().map(|r| r.0).collect();
            Ok(MaterialData {
                name: m.name.clone(),
                source: m.source_text(),
                report,
                microfacet,
                maps,
                reps,
            })
        })
        .collect()
}

/// Keys of a map's entry in results.json copied from its metrics.json.
const MAP_KEYS: [&str; 9] = [
    "noise_floor",
    "spp",
    "spp_max",
    "passes",
    "batches",
    "exposure",
    "noise_target_met",
    "interval_target_met",
    "equal_time_budget",
];

/// DIR/results.json's content (format in docs/study.md): per material the selected model
/// and, per environment map, the noise floor and every representation's error with its
/// interval, FLIP and equal-time error, from the renders' metrics.json files.
fn results(ctx: &Context<'_>, mats: &[StudyMaterial]) -> Result<Value, Error> {
    let l = ctx.layout;
    let mut materials = serde_json::Map::new();
    for m in mats {
        let report = report::read(&l.fit(&m.name))?;
        let mut maps = serde_json::Map::new();
        for e in ctx.envs {
            let v = lobe_materials::json::read(&l.renders(&m.name, &e.name).join("metrics.json"))?;
            let mut errors = serde_json::Map::new();
            for r in v["rows"].as_array().into_iter().flatten() {
                let mut entry = r["error"].clone();
                entry["equal_time"] = r["equal_time"].clone();
                entry["curve"] = r["curve"].clone();
                errors.insert(r["name"].as_str().unwrap_or("").to_string(), entry);
            }
            let mut map: serde_json::Map<String, Value> = MAP_KEYS
                .iter()
                .map(|k| (k.to_string(), v[k].clone()))
                .collect();
            map.insert("errors".into(), Value::Object(errors));
            maps.insert(e.name.clone(), Value::Object(map));
        }
        let selected = report.selected.as_ref().map(|s| s.model.clone());
        materials.insert(
            m.name.clone(),
            serde_json::json!({"selected": selected, "maps": maps}),
        );
    }
    Ok(serde_json::json!({
        "format_version": 1,
        "settings": ctx.settings.to_json(),
        "materials": materials,
    }))
}

/// The error entry of representation `rep` under the `env`-th environment map.
fn row<'a>(d: &'a MaterialData, env: usize, rep: &str) -> Option<&'a Value> {
    d.maps.get(env)?.1["errors"].get(rep)
}

/// An error's RMSE, interval, FLIP and equal-time RMSE.
fn error_numbers(r: Option<&Value>) -> [Option<f64>; 5] {
    let g = |p: &str| r.and_then(|r| r.pointer(p)).and_then(Value::as_f64);
    [
        g("/rmse"),
        g("/ci95/0"),
        g("/ci95/1"),
        g("/flip"),
        g("/equal_time/rmse"),
    ]
}

/// The interval cell "[lo, hi]", sorted by its width; `timed` as in [`num`].
fn interval(lo: Option<f64>, hi: Option<f64>, timed: bool) -> String {
    let class = timed_class(timed);
    match (lo, hi) {
        (Some(a), Some(b)) => {
            format!("<td{class} data-v=\"{:e}\">[{a:.3e}, {b:.3e}]</td>", b - a)
        }
        _ => format!("<td{class}></td>"),
    }
}

/// The ranking of the fits under one map, best first: "<" only where the 95 % interval
/// lies wholly above every better one's, "\u{2248}" where they overlap (no claim made).
pub fn ranking(errors: &serde_json::Map<String, Value>) -> String {
    let mut v: Vec<(&String, f64, f64, f64)> = errors
        .iter()
        .filter(|(k, _)| k.as_str() != "measured")
        .filter_map(|(k, e)| {
            let g = |p: &str| e.pointer(p).and_then(Value::as_f64);
            Some((k, g("/rmse")?, g("/ci95/0")?, g("/ci95/1")?))
        })
        .collect();
    v.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(b.0)));
    let mut s = String::new();
    for (i, (k, _, lo, _)) in v.iter().enumerate() {
        if i > 0 {
            let separated = v[..i].iter().all(|p| p.3 < *lo);
            s += if separated { " < " } else { " \u{2248} " };
        }
        s += k;
    }
    s
}

/// Eq. (1) normalized error, eval and sample ns of a representation.
fn brdf_numbers(d: &MaterialData, rep: &str) -> (Option<f64>, Option<f64>, Option<f64>) {
    let costs = d.report.selected.as_ref().map(|s| &s.costs);
    match rep {
        "measured" | "sampled-microfacet" => {
            let c = &d.microfacet["costs"][rep];
            let e = if rep == "measured" {
                Some(0.0)
            } else {
                d.microfacet["error_normalized"].as_f64()
            };
            (e, c["eval_ns"].as_f64(), c["sample_ns"].as_f64())
        }
        _ => {
            let c = costs.and_then(|c| c.get(rep));
            (
                d.report.models.get(rep).map(|f| f.error_normalized),
                c.map(|c| c.eval_ns),
                c.map(|c| c.sample_ns),
            )
        }
    }
}

/// The trade-off table: per material a heading and a table of its representations
/// (HTML), and one row per material and representation (Markdown and CSV); image errors
/// under the first environment map.
fn tradeoff(data: &[MaterialData]) -> (String, String, String) {
    let mut html = String::new();
    let head = "<table class=\"sortable\">\n<thead><tr><th>representation</th><th>Eq. (1) error</th><th>image RMSE</th><th>95 % interval</th><th>FLIP</th><th>RMSE at equal time</th><th>eval</th><th>sample</th></tr></thead>\n<tbody>\n";
    let mut md = String::from(
        "| material | representation | Eq. (1) error (normalized) | image RMSE | 95 % interval | FLIP | RMSE at equal time | eval ns | sample ns |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    let mut csv = String::from(
        "material,representation,eq1_error_normalized,image_rmse,image_rmse_ci95_lo,image_rmse_ci95_hi,flip,equal_time_rmse,eval_ns,sample_ns\n",
    );
    let f = |x: Option<f64>| x.map_or(String::new(), |x| format!("{x:.4e}"));
    for d in data {
        let _ = writeln!(
            html,
            "<h3><a href=\"{}\">{}</a></h3>",
            url(&format!("materials/{}.html", d.name)),
            esc(&d.name)
        );
        let mut rows = String::from(head);
        for rep in &d.reps {
            let (e, ev, sa) = brdf_numbers(d, rep);
            let [rmse, lo, hi, flip, eq] = error_numbers(row(d, 0, rep));
            let _ = writeln!(
                rows,
                "<tr><td>{}</td>{}{}{}{}{}{}{}</tr>",
                esc(rep),
                num(e, false),
                num(rmse, false),
                interval(lo, hi, false),
                num(flip, false),
                num(eq, true),
                plain_cell(ev, " ns", true),
                plain_cell(sa, " ns", true)
            );
            let ci = format!("[{}, {}]", f(lo), f(hi));
            let cells = [f(e), f(rmse), ci, f(flip), f(eq), f(ev), f(sa)];
            let _ = writeln!(md, "| {} | {rep} | {} |", d.name, cells.join(" | "));
            let cells = [f(e), f(rmse), f(lo), f(hi), f(flip), f(eq), f(ev), f(sa)];
            let _ = writeln!(csv, "{},{rep},{}", d.name, cells.join(","));
        }
        html += &scroll(&(rows + "</tbody>\n</table>\n"));
    }
    (html, md, csv)
}

/// The overview table: per material the selected model, every model's normalized error
/// and the microfacet estimate's.
fn overview_table(data: &[MaterialData], models: &[String]) -> String {
    let mut s = String::from(
        "<table class=\"sortable\" id=\"errors\">\n<thead><tr><th>material</th><th>selected model</th><th>max albedo</th>",
    );
    for m in models {
        let _ = write!(s, "<th>{}</th>", esc(m));
    }
    s += "<th>sampled-microfacet</th></tr></thead>\n<tbody>\n";
    for d in data {
        let sel = d.report.selected.as_ref().map_or("", |x| x.model.as_str());
        let _ = write!(
            s,
            "<tr><td><a href=\"{}\">{}</a></td><td>{}</td>{}",
            url(&format!("materials/{}.html", d.name)),
            esc(&d.name),
            esc(sel),
            plain_cell(Some(d.report.max_albedo), "", false)
        );
        let best = models
            .iter()
            .filter_map(|m| d.report.models.get(m).map(|f| f.error_normalized))
            .fold(f64::INFINITY, f64::min);
        for m in models {
            let e = d.report.models.get(m).map(|f| f.error_normalized);
            let cell = num(e, false);
            s += &match e == Some(best) {
                true => cell.replacen("<td", "<td class=\"best\"", 1),
                false => cell,
            };
        }
        s += &num(d.microfacet["error_normalized"].as_f64(), false);
        s += "</tr>\n";
    }
    scroll(&(s + "</tbody>\n</table>\n"))
}

/// The index page.
fn index(
    ctx: &Context<'_>,
    data: &[MaterialData],
    fig5: bool,
    trade_rows: &str,
    failures: &[(String, String)],
) -> String {
    let reports: Vec<&FitReport> = data.iter().map(|d| &d.report).collect();
    let models = crate::reports::model_labels(&reports);
    let s = ctx.settings;
    let envs: Vec<&str> = ctx.envs.iter().map(|e| e.name.as_str()).collect();
    let mut b = format!(
        "<h1>BRDF model study: {} materials</h1>\n<p class=\"note\">The experiment of Ngan, Durand and Matusik 2005 (sections 3 to 5), run by <code>lobe study</code>: \
         every model fitted to each material (Eq. 1 metric, {}\u{b0} bins, {} objective evaluations per start), the cheapest model within {} % of the best error selected, \
         the microfacet distribution estimated from the data, and {}-pixel images of a sphere under {}, every fit's difference from the measured data's image estimated from the same samples as the data's, \
         with its RMSE against the data's image, a 95 % interval and the noise floor (numbers in <a href=\"results.json\">results.json</a>). \
         Errors are normalized by the material's largest albedo. The selection ranks models by the committed cost table (the same on every run); <i>italic</i> values come from this run's timings and vary from run to run; each row's best model is highlighted. Click a column to sort.</p>\n",
        data.len(),
        s.resolution,
        s.max_evals,
        s.tolerance * 100.0,
        s.size,
        esc(&envs.join(" and ")),
    );
    if !failures.is_empty() {
        b += "<h2>Materials that failed</h2>\n<p class=\"note\">Not in this report: each stopped at the error shown. Fix or remove the file and rerun; the study resumes.</p>\n<ul>\n";
        for (name, error) in failures {
            b += &format!("<li><b>{}</b>: {}</li>\n", esc(name), esc(error));
        }
        b += "</ul>\n";
    }
    b += "<h2>Fitting error per model</h2>\n";
    b += &overview_table(data, &models);
    b += "<h2>Figures</h2>\n<div class=\"grid\">\n";
    b += &plot(
        &Layout::figure_rel("figure14"),
        "Figure 14: fitting error of every model per material",
        true,
    );
    if fig5 {
        b += &plot(
            &Layout::figure_rel("figure5"),
            "Figure 5: one lobe against two",
            true,
        );
    }
    b += "</div>\n<h2>Trade-off: image error and cost</h2>\n";
    let _ = writeln!(
        b,
        "<p class=\"note\">Image errors under {} against the measured data's image, with 95 % intervals; equal time: the error each representation's path-traced render reaches in the time the data's takes, from its fitted speed/accuracy curve. Also in <a href=\"tradeoff.md\">tradeoff.md</a> and <a href=\"tradeoff.csv\">tradeoff.csv</a>.</p>",
        esc(envs.first().copied().unwrap_or(""))
    );
    b += trade_rows;
    page("BRDF model study", &b)
}

/// The FLIP colour bar: the heat maps' magma scale from 0 (no visible difference) to 1.
fn colour_bar() -> String {
    let stops: Vec<String> = lobe_renderer::compare::flip_colour_scale(11)
        .iter()
        .enumerate()
        .map(|(i, c)| format!("rgb({},{},{}) {}%", c[0], c[1], c[2], i * 10))
        .collect();
    format!(
        "<div class=\"bar\"><span>FLIP 0</span><span class=\"scale\" style=\"background:linear-gradient(to right,{})\"></span><span>1</span></div>\n",
        stops.join(",")
    )
}

/// The renders of one environment map: the measured data's image (the reference) first,
/// then each representation (linked to full size) with its error, interval and FLIP, and
/// its FLIP map against the reference under it.
fn render_grid(d: &MaterialData, env: usize) -> String {
    let (name, m) = &d.maps[env];
    let dir = format!("../{}", Layout::renders_rel(&d.name, name));
    let mut s = format!(
        "<h3>Under {}</h3>\n<p class=\"note\">{} spp per pixel on average{} in the last pass, {} batches, each fit's difference from the same samples as the data's (common random numbers; a fit whose estimate met its targets in an earlier pass is reported from that pass, with fewer samples, and pictured as the reference plus its difference); exposure {:+.2} stops (under 1 % of the reference's pixels clip). Noise floor {:.2e}: the RMS noise left in the closest fit's difference image (each fit's own is in the table of image errors). Below each fit: its FLIP map against the reference.</p>\n",
        esc(name),
        m["spp"],
        match m["spp_max"].as_u64() {
            Some(most) => format!(" (up to {most} where the differences are noisiest)"),
            None => String::new(),
        },
        m["batches"],
        m["exposure"].as_f64().unwrap_or(0.0),
        m["noise_floor"].as_f64().unwrap_or(f64::NAN),
    );
    s += &colour_bar();
    s += "<div class=\"grid\">\n";
    for rep in &d.reps {
        let [rmse, lo, hi, flip, _] = error_numbers(row(d, env, rep));
        let f = |x: Option<f64>| x.map_or("?".into(), |x| format!("{x:.2e}"));
        let img = url(&format!("{dir}/{rep}.png"));
        let heat = url(&format!("{dir}/{rep}-flip.png"));
        let (title, under) = match rep.as_str() {
            "measured" => (
                "measured (reference)".to_string(),
                format!("its own noise {}", f(rmse)),
            ),
            _ => (
                rep.clone(),
                format!(
                    "RMSE {} [{}, {}]<br>FLIP {:.4}",
                    f(rmse),
                    f(lo),
                    f(hi),
                    flip.unwrap_or(f64::NAN)
                ),
            ),
        };
        let heat_img = match rep.as_str() {
            "measured" => String::new(),
            _ => format!(
                "<br><a href=\"{heat}\"><img class=\"render\" src=\"{heat}\" alt=\"FLIP map of {}\"></a>",
                esc(rep)
            ),
        };
        let _ = writeln!(
            s,
            "<figure><a href=\"{img}\"><img class=\"render\" src=\"{img}\" alt=\"{t}\"></a>{heat_img}<figcaption><b>{t}</b><br>{under}</figcaption></figure>",
            t = esc(&title),
        );
    }
    s + "</div>\n"
}

/// The fitted models' table: errors, start agreement, cost, parameters.
fn fits_table(d: &MaterialData) -> String {
    let sel = d.report.selected.as_ref();
    let mut s = String::from(
        "<table class=\"sortable\">\n<thead><tr><th>model</th><th>normalized error</th><th>Eq. (1) error</th><th>starts agreeing</th><th>eval ns</th><th>sample ns</th><th>parameters</th></tr></thead>\n<tbody>\n",
    );
    for (label, f) in &d.report.models {
        let cost = sel.and_then(|x| x.costs.get(label));
        let mark = if sel.is_some_and(|x| &x.model == label) {
            " (selected)"
        } else {
            ""
        };
        let _ = writeln!(
            s,
            "<tr><td>{}{mark}</td>{}{}<td data-v=\"{}\">{} of {}</td>{}{}<td>{}</td></tr>",
            esc(label),
            num(Some(f.error_normalized), false),
            num(Some(f.error), false),
            f.starts_agreeing,
            f.starts_agreeing,
            f.starts,
            plain_cell(cost.map(|c| c.eval_ns), " ns", true),
            plain_cell(cost.map(|c| c.sample_ns), " ns", true),
            params_table(&f.material)
        );
    }
    let mf = &d.microfacet;
    let _ = writeln!(
        s,
        "<tr><td>sampled-microfacet (estimated)</td>{}{}<td></td>{}{}<td>{}</td></tr>",
        num(mf["error_normalized"].as_f64(), false),
        num(mf["error"].as_f64(), false),
        plain_cell(
            mf["costs"]["sampled-microfacet"]["eval_ns"].as_f64(),
            " ns",
            true
        ),
        plain_cell(
            mf["costs"]["sampled-microfacet"]["sample_ns"].as_f64(),
            " ns",
            true
        ),
        params_table(&mf["material"])
    );
    scroll(&(s + "</tbody>\n</table>\n"))
}

/// A material's image-error table under one map, with the ranking of its fits.
fn error_table(env: &str, m: &Value) -> String {
    let empty = serde_json::Map::new();
    let errors = m["errors"].as_object().unwrap_or(&empty);
    let mut b = format!(
        "<h3>Under {}</h3>\n<p>Ranking (\u{201c}&lt;\u{201d} only where the 95 % intervals separate): {}</p>\n<p class=\"note\">Noise: the RMS noise of each fit's difference image from the data's (for the measured data, of its own image); the noise floor {:.3e} is the closest fit's. Pass (spp): the pass each error comes from (the first whose estimate met its targets, or the last) and its mean samples per pixel. Targets: every fit's noise under 10 % of its error {}, every interval narrower than 20 % of its error {}. Equal time: the error each representation reaches in the time the measured data's render takes at {} spp, from its speed/accuracy curve.</p>\n<table class=\"sortable\">\n<thead><tr><th>representation</th><th>RMSE</th><th>95 % interval</th><th>noise</th><th>pass (spp)</th><th>FLIP</th><th>spp at equal time</th><th>RMSE at equal time</th><th>its 95 % interval</th><th>time per spp</th></tr></thead>\n<tbody>\n",
        esc(env),
        esc(&ranking(errors)),
        m["noise_floor"].as_f64().unwrap_or(f64::NAN),
        if m["noise_target_met"] == true {
            "met"
        } else {
            "<b>not met</b>"
        },
        if m["interval_target_met"] == true {
            "met"
        } else {
            "<b>not met</b>"
        },
        m["equal_time_budget"]["spp"],
    );
    for (name, r) in errors {
        let g = |p: &str| r.pointer(p).and_then(Value::as_f64);
        let mark = match (name.as_str(), r["negligible"] == true) {
            ("measured", _) => " (its image's own noise, not a comparison)",
            (_, true) => " (indistinguishable)",
            (_, false) => "",
        };
        let _ = writeln!(
            b,
            "<tr><td>{}{mark}</td>{}{}{}<td>{}</td>{}{}{}{}{}</tr>",
            esc(name),
            num(g("/rmse"), false),
            interval(g("/ci95/0"), g("/ci95/1"), false),
            num(g("/noise"), false),
            match (r["pass"].as_u64(), r["spp"].as_u64()) {
                (Some(pass), Some(spp)) => format!("{pass} ({spp})"),
                _ => String::new(),
            },
            num(g("/flip"), false),
            plain_cell(g("/equal_time/spp"), "", true),
            num(g("/equal_time/rmse"), true),
            interval(g("/equal_time/ci95/0"), g("/equal_time/ci95/1"), true),
            plain_cell(g("/curve/seconds_per_spp").map(|x| x * 1e3), " ms", true),
        );
    }
    let head = b.find("<table").unwrap_or(b.len());
    let (text, table) = b.split_at(head);
    format!("{text}{}", scroll(&format!("{table}</tbody>\n</table>\n")))
}

/// A material's page.
fn material_page(ctx: &Context<'_>, d: &MaterialData) -> String {
    let mut b = format!(
        "<p><a href=\"../index.html\">\u{2190} all materials</a></p>\n<h1>{}</h1>\n<p class=\"note\">Data: <code>{}</code>; {} bins, max albedo {:.4}.</p>\n<h2>Renders</h2>\n",
        esc(&d.name),
        esc(&d.source),
        d.report.samples,
        d.report.max_albedo
    );
    for k in 0..d.maps.len() {
        b += &render_grid(d, k);
    }
    b += "<h2>Fits</h2>\n";
    b += &fits_table(d);
    b += "<h2>Image errors</h2>\n";
    for (env, m) in &d.maps {
        b += &error_table(env, m);
    }
    let shown = headline_fits(&d.report, 4).join(", ");
    let _ = write!(
        b,
        "<h2>Plots</h2>\n<p class=\"note\">The data and its fits {}: polar plots of the incidence plane (Figure 4) and iso-contours over the outgoing hemisphere (Figures 7 and 8), green channel; the estimated microfacet distribution (log10 p over the projected hemisphere).</p>\n<div class=\"grid\">\n",
        esc(&shown)
    );
    for &a in &ctx.settings.angles {
        b += &plot(
            &format!("../{}", Layout::figure_rel(&Layout::polar_name(&d.name, a))),
            "polar plot",
            true,
        );
    }
    for &a in &ctx.settings.angles {
        b += &plot(
            &format!("../{}", Layout::figure_rel(&Layout::lobes_name(&d.name, a))),
            "lobe plot",
            true,
        );
    }
    b += &plot(
        &format!("../microfacet/{}.png", d.name),
        "estimated microfacet distribution",
        false,
    );
    b += "</div>\n";
    page(&d.name, &b)
}

/// Writes a text file atomically.
fn write_text(path: &Path, text: &str) -> Result<(), Error> {
    lobe_renderer::film::atomic_write(path, |w| std::io::Write::write_all(w, text.as_bytes()))
}

/// Builds the report from the finished steps of every material: Figures 14 and 5, the
/// trade-off table, the pages; returns the index page's path.
/// Builds the report of the complete materials `mats`; `failures` (material, error) are
/// listed on the index page.
pub fn build(
    ctx: &Context<'_>,
    mats: &[StudyMaterial],
    failures: &[(String, String)],
) -> Result<PathBuf, Error> {
    let l = ctx.layout;
    let results_path = l.root.join("results.json");
    lobe_renderer::film::write_json(&results_path, &results(ctx, mats)?)?;
    let data = gather(ctx, mats, &lobe_materials::json::read(&results_path)?)?;
    let reports: Vec<FitReport> = data.iter().map(|d| d.report.clone()).collect();
    std::fs::create_dir_all(l.root.join("materials"))
        .and_then(|_| std::fs::create_dir_all(l.root.join("figures")))
        .map_err(|e| Error::file(l.root.display(), format!("cannot create: {e}")))?;
    let microfacet: Vec<figures::ExtraError> = data
        .iter()
        .filter_map(|d| {
            let e = d.microfacet["error_normalized"].as_f64()?;
            Some((d.report.material.clone(), "sampled-microfacet".into(), e))
        })
        .collect();
    figures::errors_with(&reports, &microfacet)?.save(&l.figure("figure14"))?;
    let fig5 = match figures::multilobe(&reports) {
        Ok(f) => {
            f.save(&l.figure("figure5"))?;
            true
        }
        Err(_) => false,
    };
    let (rows, md, csv) = tradeoff(&data);
    write_text(&l.root.join("tradeoff.md"), &md)?;
    write_text(&l.root.join("tradeoff.csv"), &csv)?;
    for d in &data {
        let p = l.root.join("materials").join(format!("{}.html", d.name));
        write_text(&p, &material_page(ctx, d))?;
    }
    let index_path = l.root.join("index.html");
    write_text(&index_path, &index(ctx, &data, fig5, &rows, failures))?;
    Ok(index_path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_have_three_significant_digits_and_counts_are_plain() {
        assert_eq!(
            num(Some(0.469_812), false),
            "<td data-v=\"4.69812e-1\">4.70e-1</td>"
        );
        assert_eq!(num(Some(f64::NAN), true), "<td class=\"timed\"></td>");
        let cases = [
            (32.0, "32"),
            (75.389, "75.4"),
            (33.19, "33.2"),
            (7.024, "7.02"),
            (0.4532, "0.453"),
            (0.007_024, "0.00702"),
            (1234.5, "1234"),
            (0.0, "0"),
        ];
        for (x, s) in cases {
            assert_eq!(plain(x), s, "{x}");
        }
        assert_eq!(
            plain_cell(Some(33.19), " ns", true),
            "<td class=\"timed\" data-v=\"3.319e1\">33.2 ns</td>"
        );
    }

    #[test]
    fn parameters_are_a_table_with_a_row_per_parameter_and_lobe() {
        let v = serde_json::json!({"type": "composite", "diffuse": [0.1, 0.2, 0.3],
            "lobes": [{"type": "ward", "alpha": 0.123456}]});
        let t = params_table(&v);
        assert!(t.starts_with("<table class=\"params\">"), "{t}");
        assert!(
            t.contains("<td>diffuse</td><td>[0.1, 0.2, 0.3]</td>"),
            "{t}"
        );
        assert!(t.contains("lobe 1: <table class=\"params\">"), "{t}");
        assert!(t.contains("<td>alpha</td><td>0.12346</td>"), "{t}");
        assert!(t.contains("<td>type</td><td>ward</td>"), "{t}");
    }
}
