//! Light sampling: for every area-light shape, the density `sample_li` reports equals
//! `pdf_area` at the sampled point, and the densities integrate to one over the solid
//! angle the light subtends (checked by estimating the light's solid angle both ways).
//! Radiance HDR environment maps load like OpenEXR ones.

use glam::{Mat4, Vec2, Vec3};
use lobe_materials::Rgb;
use lobe_renderer::geometry::{Interaction, Mesh, Rectangle, Sphere, Triangle};
use lobe_renderer::lights::{AreaShape, Light};

fn lights() -> Vec<(&'static str, Light)> {
    let rect = Rectangle::from_transform(
        &(Mat4::from_translation(Vec3::new(0.3, 2.0, -0.2)) * Mat4::from_rotation_x(1.9)),
    )
    .unwrap();
    let mesh = Mesh {
        positions: vec![
            Vec3::new(-1.0, 3.0, -1.0),
            Vec3::new(1.0, 3.0, -1.0),
            Vec3::new(1.0, 3.5, 1.0),
            Vec3::new(-1.0, 2.5, 1.5),
        ],
        indices: vec![[0, 2, 1], [0, 3, 2]],
        ..Default::default()
    };
    let tris: Vec<(Triangle, Vec3)> = (0..2)
        .map(|i| {
            let t = Triangle::new(0, &mesh, i);
            (t, -t.normal())
        })
        .collect();
    let radiance = Rgb::ONE;
    vec![
        (
            "sphere (outside)",
            Light::Area {
                shape: AreaShape::Sphere {
                    sphere: Sphere {
                        center: Vec3::new(0.5, 2.0, 0.0),
                        radius: 0.7,
                    },
                    flip: false,
                },
                radiance,
            },
        ),
        (
            "sphere (inside)",
            Light::Area {
                shape: AreaShape::Sphere {
                    sphere: Sphere {
                        center: Vec3::new(0.1, 0.0, 0.0),
                        radius: 3.0,
                    },
                    flip: true,
                },
                radiance,
            },
        ),
        (
            "rectangle",
            Light::Area {
                shape: AreaShape::Rectangle { rect, flip: false },
                radiance,
            },
        ),
        (
            "mesh",
            Light::Area {
                shape: AreaShape::mesh(tris).unwrap(),
                radiance,
            },
        ),
    ]
}

fn hash(k: u32, salt: u32) -> f32 {
    let mut x = (k as u64) << 32 | salt as u64;
    x = lobe_renderer::sampler::mix64(x);
    ((x >> 40) as f32) / (1u64 << 24) as f32
}

#[test]
fn sampled_density_matches_pdf_and_integrates_to_one() {
    let p = Vec3::ZERO;
    for (name, light) in lights() {
        let n = 200_000u32;
        let mut inv_pdf_sum = 0.0f64; // E[1 / pdf] = solid angle covered by the samples
        let mut count = 0;
        for k in 0..n {
            let u = Vec2::new(hash(k, 1), hash(k, 2));
            let Some(ls) = light.sample_li(p, u) else {
                continue;
            };
            let (q, nq) = ls.p.expect("area lights sample points");
            let it = Interaction {
                t: 0.0,
                p: q,
                ng: nq,
                ns: nq,
                dpdu: Vec3::X,
                uv: Vec2::ZERO,
                shape: 0,
                prim: 0,
                exit: Vec3::ZERO,
            };
            let pdf = light.pdf_area(p, &it);
            assert!(
                (pdf - ls.pdf).abs() <= 2e-3 * ls.pdf,
                "{name}: sample pdf {} vs pdf_area {pdf}",
                ls.pdf
            );
            inv_pdf_sum += 1.0 / ls.pdf as f64;
            count += 1;
        }
        // Solid angle of the light seen from p, by brute force over directions.
        let m = 1_000_000u32;
        let mut hits = 0u32;
        for k in 0..m {
            let d = lobe_materials::sampling::warp::square_to_uniform_sphere(Vec2::new(
                hash(k, 3),
                hash(k, 4),
            ));
            let ray = lobe_renderer::geometry::Ray::new(p, d);
            let hit = match &light {
                Light::Area {
                    shape: AreaShape::Sphere { sphere, .. },
                    ..
                } => sphere.intersect(&ray).is_finite(),
                Light::Area {
                    shape: AreaShape::Rectangle { rect, .. },
                    ..
                } => rect.intersect(&ray).is_finite(),
                Light::Area {
                    shape: AreaShape::Mesh { tris, .. },
                    ..
                } => tris.iter().any(|(t, _)| t.intersect(&ray).is_finite()),
                _ => unreachable!(),
            };
            hits += hit as u32;
        }
        let omega = 4.0 * std::f64::consts::PI * hits as f64 / m as f64;
        let estimate = inv_pdf_sum / n as f64;
        assert!(
            count as f64 > 0.99 * n as f64,
            "{name}: only {count} samples"
        );
        assert!(
            (estimate - omega).abs() < 0.02 * omega,
            "{name}: E[1/pdf] = {estimate} but the light subtends {omega} sr"
        );
    }
}

#[test]
fn radiance_hdr_env_maps_load() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("env.hdr");
    let (w, h) = (8u32, 4u32);
    let pixels: Vec<image::Rgb<f32>> = (0..w * h)
        .map(|i| image::Rgb([i as f32 * 0.5, 1.0, 2.0]))
        .collect();
    let file = std::fs::File::create(&path).unwrap();
    image::codecs::hdr::HdrEncoder::new(file)
        .encode(&pixels, w as usize, h as usize)
        .unwrap();
    let img = lobe_renderer::lights::envmap::load_rgb_image(&path).unwrap();
    assert_eq!((img.width, img.height), (8, 4));
    // RGBE keeps about 1 % precision.
    assert!(
        (img.pixels[5].r - 2.5).abs() < 0.05 && (img.pixels[5].b - 2.0).abs() < 0.03,
        "{:?}",
        img.pixels[5]
    );
}

/// `sample_li_many` gives bit for bit what `sample_li` gives at each point, for every
/// light kind (area lights of each shape, flipped rectangles, points behind and on the
/// emitter's plane, a point light, an env map), in batches of odd sizes (partial SIMD
/// chunks).
#[test]
fn batched_light_samples_equal_single_ones() {
    let mut all = lights();
    let rect = Rectangle::from_transform(&Mat4::from_rotation_x(0.3)).unwrap();
    all.push((
        "rectangle (flipped)",
        Light::Area {
            shape: AreaShape::Rectangle { rect, flip: true },
            radiance: Rgb::new(1.0, 2.0, 3.0),
        },
    ));
    all.push((
        "point",
        Light::Point {
            position: Vec3::new(0.0, 1.0, 0.5),
            intensity: Rgb::ONE,
        },
    ));
    let img = lobe_renderer::image_io::RgbImage {
        width: 8,
        height: 4,
        pixels: (0..32).map(|k| Rgb::splat(0.1 + k as f32)).collect(),
    };
    all.push((
        "env",
        Light::Env(Box::new(lobe_renderer::lights::EnvMap::new(
            &img,
            1.0,
            glam::Mat3::IDENTITY,
        ))),
    ));
    let points: Vec<Vec3> = (0..53)
        .map(|k| match k % 7 {
            0 => Vec3::ZERO, // on the plane of the rotated rectangle
            1 => Vec3::new(0.3, 2.0, -0.2),
            _ => Vec3::new(hash(k, 3), hash(k, 4), hash(k, 5)) * 6.0 - 3.0,
        })
        .collect();
    let us: Vec<Vec2> = (0..53).map(|k| Vec2::new(hash(k, 6), hash(k, 7))).collect();
    let mut out = lobe_renderer::lights::LightSamples::default();
    let mut samples = 0;
    for (name, light) in &all {
        for len in [53, 8, 5, 1] {
            let u = lobe_materials::Vec2s::from(&us[..len]);
            let p = lobe_materials::Vec3s::from(&points[..len]);
            light.sample_li_many(p.cols(), u.cols(), &mut out);
            assert_eq!(out.pdf.len(), len);
            for k in 0..len {
                let one = light.sample_li(points[k], us[k]);
                match one {
                    None => assert_eq!(out.pdf[k], 0.0, "{name}, point {k}: no sample"),
                    Some(ls) => {
                        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                        assert_eq!(bits(out.wi.get(k)), bits(ls.wi), "{name}, point {k}");
                        assert_eq!(out.li[k], ls.li, "{name}, point {k}");
                        assert_eq!(out.pdf[k].to_bits(), ls.pdf.to_bits(), "{name}, point {k}");
                        assert_eq!(out.delta[k], ls.delta, "{name}, point {k}");
                        assert_eq!(out.at[k], ls.p, "{name}, point {k}");
                        samples += 1;
                    }
                }
            }
        }
    }
    assert!(samples > 300, "only {samples} samples compared");
}
