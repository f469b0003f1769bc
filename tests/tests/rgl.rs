//! RGL measured BSDFs against Mitsuba 3.9.1's `measured` plugin: values, densities and
//! samples of the four CC0 files of ../shared/data/rgl at fixed directions, as printed by
//! Mitsuba (`scalar_rgb`; the script is in the test's doc below), must agree to 1e-3.
//!
//! The values were produced with `mi.load_dict({"type": "measured", "filename": F})` and
//! `bsdf.eval/pdf/sample` with `si.wi` = direction (theta, phi) = the first pair, the
//! queried direction the second; Mitsuba's `eval` includes cos(theta) of the queried
//! direction, which is lobe's `Rgl::eval_projected` (negative table values included; the
//! `rgl` material clamps them unless `"clamp": false`).

use glam::{Vec2, Vec3};
use lobe_materials::measured::rgl::Rgl;

enum Kind {
    Eval,
    Sample,
}

/// (file, kind, [theta_wi, phi_wi, theta_wo, phi_wo] or [u.x, u.y, _, _],
///  [r, g, b, pdf] or [wo.x, wo.y, wo.z, pdf, r, g, b]).
const GOLDEN: &[(&str, Kind, [f64; 4], &[f64])] = &[
    (
        "cc_ibiza_sunset_rgb.bsdf",
        Kind::Eval,
        [0.3, 0.2, 0.5, 2.0],
        &[
            0.05643269047141075,
            0.02343612164258957,
            0.026904061436653137,
            0.20139147341251373,
        ],
    ),
    (
        "cc_ibiza_sunset_rgb.bsdf",
        Kind::Eval,
        [0.0001, 0.0, 0.4, 3.1],
        &[
            0.06694316118955612,
            0.026339827105402946,
            0.037489812821149826,
            0.2450006902217865,
        ],
    ),
    (
        "cc_ibiza_sunset_rgb.bsdf",
        Kind::Eval,
        [0.8, -1.0, 0.8, 2.14159],
        &[
            2.4794163703918457,
            1.3162693977355957,
            0.9691517949104309,
            14.254077911376953,
        ],
    ),
    (
        "cc_ibiza_sunset_rgb.bsdf",
        Kind::Eval,
        [1.2, 0.5, 0.3, -2.5],
        &[
            0.015598795376718044,
            0.006494365632534027,
            0.0026689034420996904,
            0.03210948035120964,
        ],
    ),
    (
        "cc_ibiza_sunset_rgb.bsdf",
        Kind::Eval,
        [0.5, 0.7, 0.9, -2.0],
        &[
            0.06756328791379929,
            0.023482393473386765,
            0.014641206711530685,
            0.20277996361255646,
        ],
    ),
    (
        "cc_ibiza_sunset_rgb.bsdf",
        Kind::Eval,
        [1.4, 0.1, 1.3, 3.0],
        &[
            0.16355125606060028,
            0.11887633800506592,
            0.05430984869599342,
            0.31489574909210205,
        ],
    ),
    (
        "cc_ibiza_sunset_rgb.bsdf",
        Kind::Sample,
        [0.25, 0.75, 0.0, 0.0],
        &[
            -0.12842829525470734,
            -0.5777264833450317,
            0.8060633540153503,
            0.8719205856323242,
            0.2736523747444153,
            0.12693946063518524,
            0.13658742606639862,
        ],
    ),
    (
        "cc_ibiza_sunset_rgb.bsdf",
        Kind::Sample,
        [0.5, 0.5, 0.0, 0.0],
        &[
            -0.21540726721286774,
            -0.18143491446971893,
            0.9595210552215576,
            1.2213544845581055,
            0.3430522084236145,
            0.10231467336416245,
            0.17367471754550934,
        ],
    ),
    (
        "cc_ibiza_sunset_rgb.bsdf",
        Kind::Sample,
        [0.9, 0.1, 0.0, 0.0],
        &[
            -0.4270665645599365,
            -0.29798752069473267,
            0.8537081480026245,
            6.166477680206299,
            0.2999004125595093,
            0.11789403855800629,
            0.14606787264347076,
        ],
    ),
    (
        "colodur_napoli_4f_rgb.bsdf",
        Kind::Eval,
        [0.3, 0.2, 0.5, 2.0],
        &[
            0.06593003123998642,
            0.016302864998579025,
            0.017255213111639023,
            0.2626025378704071,
        ],
    ),
    (
        "colodur_napoli_4f_rgb.bsdf",
        Kind::Eval,
        [0.0001, 0.0, 0.4, 3.1],
        &[
            0.07212676107883453,
            0.017781365662813187,
            0.01917942240834236,
            0.30206403136253357,
        ],
    ),
    (
        "colodur_napoli_4f_rgb.bsdf",
        Kind::Eval,
        [0.8, -1.0, 0.8, 2.14159],
        &[
            0.0834825187921524,
            0.037629298865795135,
            0.0369282104074955,
            0.712516188621521,
        ],
    ),
    (
        "colodur_napoli_4f_rgb.bsdf",
        Kind::Eval,
        [1.2, 0.5, 0.3, -2.5],
        &[
            0.08374470472335815,
            0.025185495615005493,
            0.02645210362970829,
            0.24636149406433105,
        ],
    ),
    (
        "colodur_napoli_4f_rgb.bsdf",
        Kind::Eval,
        [0.5, 0.7, 0.9, -2.0],
        &[
            0.05651022493839264,
            0.017579250037670135,
            0.018185237422585487,
            0.2429424524307251,
        ],
    ),
    (
        "colodur_napoli_4f_rgb.bsdf",
        Kind::Eval,
        [1.4, 0.1, 1.3, 3.0],
        &[
            0.09967883676290512,
            0.07628824561834335,
            0.07266002148389816,
            0.4731822907924652,
        ],
    ),
    (
        "colodur_napoli_4f_rgb.bsdf",
        Kind::Sample,
        [0.25, 0.75, 0.0, 0.0],
        &[
            0.6669408679008484,
            -0.5383657217025757,
            0.5151236057281494,
            0.14053957164287567,
            0.2818583846092224,
            0.05882123112678528,
            0.06429483741521835,
        ],
    ),
    (
        "colodur_napoli_4f_rgb.bsdf",
        Kind::Sample,
        [0.5, 0.5, 0.0, 0.0],
        &[
            0.4240054190158844,
            0.35711875557899475,
            0.8322773575782776,
            0.23140044510364532,
            0.2818530201911926,
            0.05841398611664772,
            0.06799795478582382,
        ],
    ),
    (
        "colodur_napoli_4f_rgb.bsdf",
        Kind::Sample,
        [0.9, 0.1, 0.0, 0.0],
        &[
            -0.5719141960144043,
            -0.1714704930782318,
            0.802191972732544,
            0.2895936071872711,
            0.23826204240322113,
            0.0707758367061615,
            0.07341337203979492,
        ],
    ),
    (
        "paper_white_rgb.bsdf",
        Kind::Eval,
        [0.3, 0.2, 0.5, 2.0],
        &[
            0.2290758639574051,
            0.23306526243686676,
            0.2733897864818573,
            0.2772812247276306,
        ],
    ),
    (
        "paper_white_rgb.bsdf",
        Kind::Eval,
        [0.0001, 0.0, 0.4, 3.1],
        &[
            0.25449100136756897,
            0.25920987129211426,
            0.30503764748573303,
            0.30972033739089966,
        ],
    ),
    (
        "paper_white_rgb.bsdf",
        Kind::Eval,
        [0.8, -1.0, 0.8, 2.14159],
        &[
            0.2098529040813446,
            0.21106994152069092,
            0.2401488870382309,
            0.4374171197414398,
        ],
    ),
    (
        "paper_white_rgb.bsdf",
        Kind::Eval,
        [1.2, 0.5, 0.3, -2.5],
        &[
            0.25260311365127563,
            0.2552095353603363,
            0.2942415177822113,
            0.2904823422431946,
        ],
    ),
    (
        "paper_white_rgb.bsdf",
        Kind::Eval,
        [0.5, 0.7, 0.9, -2.0],
        &[
            0.1754370778799057,
            0.17747287452220917,
            0.2048855721950531,
            0.20984894037246704,
        ],
    ),
    (
        "paper_white_rgb.bsdf",
        Kind::Eval,
        [1.4, 0.1, 1.3, 3.0],
        &[
            0.18389040231704712,
            0.18067260086536407,
            0.18513478338718414,
            0.21838532388210297,
        ],
    ),
    (
        "paper_white_rgb.bsdf",
        Kind::Sample,
        [0.25, 0.75, 0.0, 0.0],
        &[
            0.7137055993080139,
            -0.43155449628829956,
            0.5517111420631409,
            0.16563494503498077,
            0.8299600481987,
            0.8446834087371826,
            0.9920443296432495,
        ],
    ),
    (
        "paper_white_rgb.bsdf",
        Kind::Sample,
        [0.5, 0.5, 0.0, 0.0],
        &[
            0.41638264060020447,
            0.3507212698459625,
            0.8388204574584961,
            0.2635324001312256,
            0.8299655318260193,
            0.8443526029586792,
            0.992777943611145,
        ],
    ),
    (
        "paper_white_rgb.bsdf",
        Kind::Sample,
        [0.9, 0.1, 0.0, 0.0],
        &[
            -0.5515562295913696,
            -0.12279999256134033,
            0.8250489830970764,
            0.2767961919307709,
            0.8340540528297424,
            0.8450024127960205,
            0.98092120885849,
        ],
    ),
    (
        "vch_golden_yellow_rgb.bsdf",
        Kind::Eval,
        [0.3, 0.2, 0.5, 2.0],
        &[
            0.03648018836975098,
            0.030365796759724617,
            0.011913626454770565,
            0.09032431244850159,
        ],
    ),
    (
        "vch_golden_yellow_rgb.bsdf",
        Kind::Eval,
        [0.0001, 0.0, 0.4, 3.1],
        &[
            0.044510144740343094,
            0.036273568868637085,
            0.013838637620210648,
            0.10791482031345367,
        ],
    ),
    (
        "vch_golden_yellow_rgb.bsdf",
        Kind::Eval,
        [0.8, -1.0, 0.8, 2.14159],
        &[
            5.610761642456055,
            2.9098472595214844,
            -0.004477335140109062,
            18.28862190246582,
        ],
    ),
    (
        "vch_golden_yellow_rgb.bsdf",
        Kind::Eval,
        [1.2, 0.5, 0.3, -2.5],
        &[
            0.013923154212534428,
            0.013612071983516216,
            0.004290612880140543,
            0.0463898703455925,
        ],
    ),
    (
        "vch_golden_yellow_rgb.bsdf",
        Kind::Eval,
        [0.5, 0.7, 0.9, -2.0],
        &[
            0.047114234417676926,
            0.03415874391794205,
            0.011099147610366344,
            0.10471878945827484,
        ],
    ),
    (
        "vch_golden_yellow_rgb.bsdf",
        Kind::Eval,
        [1.4, 0.1, 1.3, 3.0],
        &[
            0.11314307153224945,
            0.07774579524993896,
            0.04405871033668518,
            0.28756073117256165,
        ],
    ),
    (
        "vch_golden_yellow_rgb.bsdf",
        Kind::Sample,
        [0.25, 0.75, 0.0, 0.0],
        &[
            -0.1834685206413269,
            -0.5037603378295898,
            0.8441354036331177,
            0.8830704092979431,
            0.5174931287765503,
            0.3116356134414673,
            0.04772743955254555,
        ],
    ),
    (
        "vch_golden_yellow_rgb.bsdf",
        Kind::Sample,
        [0.5, 0.5, 0.0, 0.0],
        &[
            -0.257145494222641,
            -0.21659056842327118,
            0.9417882561683655,
            2.571438789367676,
            0.5475927591323853,
            0.3065873682498932,
            0.011356273666024208,
        ],
    ),
    (
        "vch_golden_yellow_rgb.bsdf",
        Kind::Sample,
        [0.9, 0.1, 0.0, 0.0],
        &[
            -0.41074663400650024,
            -0.30523213744163513,
            0.8591393232345581,
            11.662107467651367,
            0.5811495184898376,
            0.2989990711212158,
            -0.021803580224514008,
        ],
    ),
];

fn d(t: f64, p: f64) -> Vec3 {
    Vec3::new(
        (t.sin() * p.cos()) as f32,
        (t.sin() * p.sin()) as f32,
        t.cos() as f32,
    )
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-3 * b.abs().max(1e-2)
}

#[test]
fn rgl_matches_mitsuba_measured() {
    let Some(data) = lobe_tests::shared_data_or_skip("RGL files against Mitsuba's measured") else {
        return;
    };
    let mut checked = 0;
    for file in [
        "cc_ibiza_sunset_rgb.bsdf",
        "colodur_napoli_4f_rgb.bsdf",
        "paper_white_rgb.bsdf",
        "vch_golden_yellow_rgb.bsdf",
    ] {
        let rgl = Rgl::read(&data.join("rgl").join(file)).unwrap();
        assert!(rgl.is_isotropic());
        for (f, kind, a, v) in GOLDEN.iter().filter(|g| g.0 == file) {
            match kind {
                Kind::Eval => {
                    let (wo, wi) = (d(a[0], a[1]), d(a[2], a[3]));
                    let e = rgl.eval_projected(wo, wi);
                    let p = rgl.pdf(wo, wi);
                    for (c, x) in e.to_array().into_iter().enumerate() {
                        assert!(
                            close(x as f64, v[c]),
                            "{f} eval {a:?} channel {c}: {x} vs Mitsuba {}",
                            v[c]
                        );
                    }
                    assert!(
                        close(p as f64, v[3]),
                        "{f} pdf {a:?}: {p} vs Mitsuba {}",
                        v[3]
                    );
                }
                Kind::Sample => {
                    let wo = d(0.5, 0.7);
                    let (wi, pdf) = rgl.sample(wo, Vec2::new(a[0] as f32, a[1] as f32)).unwrap();
                    assert!(
                        (wi - Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)).length() < 1e-4,
                        "{f} sample {a:?}: {wi} vs Mitsuba {v:?}"
                    );
                    assert!(close(pdf as f64, v[3]), "{f} sample pdf: {pdf} vs {}", v[3]);
                    let w = rgl.eval_projected(wo, wi) / pdf;
                    for (c, x) in w.to_array().into_iter().enumerate() {
                        assert!(
                            close(x as f64, v[4 + c]),
                            "{f} sample weight {c}: {x} vs {}",
                            v[4 + c]
                        );
                    }
                }
            }
            checked += 1;
        }
    }
    assert_eq!(checked, 36);
}

#[test]
fn rgl_material_passes_the_bsdf_battery() {
    use lobe_tests::bsdf_checks::*;
    let Some(data) = lobe_tests::shared_data_or_skip("the BSDF battery on RGL files") else {
        return;
    };
    let reg = lobe_materials::registry::Registry::builtin();
    for file in ["paper_white_rgb.bsdf", "vch_golden_yellow_rgb.bsdf"] {
        let path = data.join("rgl").join(file);
        let m = reg
            .create(
                &serde_json::json!({"type": "rgl", "file": path.to_str().unwrap()}),
                "m",
            )
            .unwrap();
        check_finite_nonnegative(file, m.as_ref());
        check_sample_consistency(file, m.as_ref());
        for wo in [dir_deg(20.0, 0.0), dir_deg(50.0, 80.0)] {
            let integral = pdf_integral(m.as_ref(), wo, 600);
            let rate = success_rate(m.as_ref(), wo, 256);
            assert!(
                (integral - rate).abs() < 0.02,
                "{file}: pdf integrates to {integral}, sampling succeeds {rate}"
            );
            let p = chi2_pvalue_sub(m.as_ref(), wo, 24, 200_000, 3, 32);
            assert!(p > 1e-3, "{file}: chi-square p = {p}");
        }
    }
}
