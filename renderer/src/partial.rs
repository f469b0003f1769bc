//! Partial renders: a range of each pixel's samples rendered on its own
//! ([`crate::render::render_samples`]), kept as per-pixel sums of the finite samples, of
//! their squares, and their count. Parts of disjoint ranges of one scene add up to the
//! whole render ([`PartialRender::merge`]), so that a render can be split over processes
//! or machines (`lobe render --samples A:B`, `lobe render merge`, Python's
//! `lobe.distributed.render`) and give the one-machine image.
//!
//! Every sample's numbers depend only on its pixel, its index and the seed (the sampler is
//! set up for the whole render's sample count), so a part computes exactly the samples the
//! whole render would. The whole render adds each pixel's samples in order in f64; a merge
//! adds the parts' f64 sums in range order, which rounds differently in the last f64 bits:
//! after the division and the rounding to f32, a pixel differs from the whole render by at
//! most one f32 step and is equal in the great majority of pixels (measured in
//! docs/distributed.md). One part over all samples is the whole render bit for bit.
//!
//! A part is identified by its scene's key ([`crate::scene::Scene::render_key`]: the
//! digest of the scene description and its folder, with the sample count, seed, scrambling
//! and film size), which a merge checks. The file format (`.lobepart`): the line
//! `lobe-partial-render 1`, one line of JSON (width, height, spp, first, last, key,
//! dropped), then per pixel in row order seven little-endian numbers: the sums of r, g, b
//! (f64), of their squares (f64) and the count of finite samples (u32).

use crate::Rgb;
use crate::error::{Error, Result};
use crate::film::Image;
use serde_json::{Value, json};

const MAGIC: &str = "lobe-partial-render 1\n";
const PIXEL_BYTES: usize = 6 * 8 + 4;

/// Per-pixel sums of one range of samples of a render.
#[derive(Clone, Debug, PartialEq)]
pub struct PartialRender {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel of the whole render.
    pub spp: u32,
    /// The samples `first..last` of every pixel, or several such ranges once merged.
    pub ranges: Vec<(u32, u32)>,
    /// The scene's key (see the module doc).
    pub key: String,
    /// Per pixel, the sums of its finite samples per channel.
    pub sum: Vec<[f64; 3]>,
    /// Per pixel, the sums of their squares.
    pub sum2: Vec<[f64; 3]>,
    /// Per pixel, its finite samples.
    pub count: Vec<u32>,
    /// Non-finite samples dropped.
    pub dropped: u64,
}

impl PartialRender {
    /// An empty part of a `width` x `height` film (fallibly allocated).
    pub fn try_new(
        (width, height): (u32, u32),
        spp: u32,
        (first, last): (u32, u32),
        key: String,
    ) -> Result<Self> {
        let n = width as usize * height as usize;
        let mut sum = Vec::new();
        let mut sum2 = Vec::new();
        let mut count = Vec::new();
        let oom = |_| {
            Error::Other(format!(
                "cannot allocate the sums of a {width}x{height} film"
            ))
        };
        sum.try_reserve_exact(n).map_err(oom)?;
        sum2.try_reserve_exact(n).map_err(oom)?;
        count.try_reserve_exact(n).map_err(oom)?;
        sum.resize(n, [0.0; 3]);
        sum2.resize(n, [0.0; 3]);
        count.resize(n, 0);
        Ok(Self {
            width,
            height,
            spp,
            ranges: vec![(first, last)],
            key,
            sum,
            sum2,
            count,
            dropped: 0,
        })
    }

    /// True when the ranges cover every sample of the render.
    pub fn is_complete(&self) -> bool {
        self.ranges == [(0, self.spp)]
    }

    /// Adds parts of one render; the result is the same whatever order they come in (they
    /// are added in the order of their ranges). Refuses parts of other scenes, film sizes
    /// or sample counts, and overlapping ranges; adjacent ranges join.
    pub fn merge(mut parts: Vec<PartialRender>) -> Result<PartialRender> {
        if parts.is_empty() {
            return Err(Error::Other("no partial renders to merge".into()));
        }
        parts.sort_by_key(|p| p.ranges.first().copied().unwrap_or_default());
        let mut it = parts.into_iter();
        let mut out = it.next().expect("one part");
        for p in it {
            let what = |field: &str, a: String, b: String| {
                Error::Other(format!(
                    "partial renders of different {field}: {a} and {b}; expected parts of one render"
                ))
            };
            if p.key != out.key {
                return Err(what("scenes or settings (key)", out.key.clone(), p.key));
            }
            if (p.width, p.height, p.spp) != (out.width, out.height, out.spp) {
                let f = |q: &PartialRender| format!("{}x{} at {} spp", q.width, q.height, q.spp);
                return Err(what("films", f(&out), f(&p)));
            }
            let end = out.ranges.last().map_or(0, |r| r.1);
            let start = p.ranges.first().map_or(0, |r| r.0);
            if start < end {
                return Err(Error::Other(format!(
                    "partial renders overlap: samples {:?} and {:?}; expected disjoint ranges",
                    out.ranges, p.ranges
                )));
            }
            for k in 0..out.sum.len() {
                for c in 0..3 {
                    out.sum[k][c] += p.sum[k][c];
                    out.sum2[k][c] += p.sum2[k][c];
                }
                out.count[k] += p.count[k];
            }
            out.dropped += p.dropped;
            for r in p.ranges {
                match out.ranges.last_mut() {
                    Some(last) if last.1 == r.0 => last.1 = r.1,
                    _ => out.ranges.push(r),
                }
            }
        }
        Ok(out)
    }

    /// The image: each pixel's mean and the variance of that mean, as a render gives them.
    /// Refuses a part that does not cover every sample.
    pub fn image(&self) -> Result<Image> {
        if !self.is_complete() {
            return Err(Error::Other(format!(
                "the partial renders cover samples {:?} of 0..{}; expected every sample",
                self.ranges, self.spp
            )));
        }
        let mut img = Image::try_new(self.width, self.height)?;
        img.variance_dof = (self.spp.max(2) - 1) as f64;
        for k in 0..self.sum.len() {
            let (m, v) = mean_and_variance(self.sum[k], self.sum2[k], self.count[k]);
            img.pixels[k] = m;
            img.variance[k] = v;
        }
        Ok(img)
    }

    fn header(&self) -> Value {
        json!({"width": self.width, "height": self.height, "spp": self.spp,
               "ranges": self.ranges, "key": self.key, "dropped": self.dropped})
    }

    /// The part in the `.lobepart` format (see the module doc).
    pub fn to_bytes(&self) -> Vec<u8> {
        let head = format!("{MAGIC}{}\n", self.header());
        let mut out = Vec::with_capacity(head.len() + self.sum.len() * PIXEL_BYTES);
        out.extend_from_slice(head.as_bytes());
        for k in 0..self.sum.len() {
            for x in self.sum[k].iter().chain(&self.sum2[k]) {
                out.extend_from_slice(&x.to_le_bytes());
            }
            out.extend_from_slice(&self.count[k].to_le_bytes());
        }
        out
    }

    /// Reads a part from its bytes; `shown` names it in errors.
    pub fn from_bytes(bytes: &[u8], shown: &str) -> Result<Self> {
        let bad = |m: String| Error::file(shown, m);
        let rest = bytes
            .strip_prefix(MAGIC.as_bytes())
            .ok_or_else(|| bad("is not a partial render; expected a file that starts with \"lobe-partial-render 1\"".into()))?;
        let end = rest
            .iter()
            .position(|&b| b == b'\n')
            .ok_or_else(|| bad("header: expected a line of JSON".into()))?;
        let head: Value = serde_json::from_slice(&rest[..end])
            .map_err(|e| bad(format!("header: expected JSON: {e}")))?;
        let field = |k: &str| {
            head.get(k)
                .ok_or_else(|| bad(format!("header: expected the field {k}")))
        };
        let int = |k: &str, max: u64| -> Result<u64> {
            field(k)?
                .as_u64()
                .filter(|&v| v <= max)
                .ok_or_else(|| bad(format!("{k}: expected an integer of at most {max}")))
        };
        let (width, height) = (int("width", 16384)? as u32, int("height", 16384)? as u32);
        let spp = int("spp", crate::limits::MAX_SPP as u64)? as u32;
        let ranges: Vec<(u32, u32)> = serde_json::from_value(field("ranges")?.clone())
            .ok()
            .filter(|r: &Vec<(u32, u32)>| {
                !r.is_empty()
                    && r.iter().all(|&(a, b)| a < b && b <= spp)
                    && r.windows(2).all(|w| w[0].1 < w[1].0)
            })
            .ok_or_else(|| {
                bad(format!(
                    "ranges: expected increasing disjoint sample ranges within 0..{spp}"
                ))
            })?;
        let key = field("key")?
            .as_str()
            .ok_or_else(|| bad("key: expected a string".into()))?
            .to_string();
        let body = &rest[end + 1..];
        let n = width as usize * height as usize;
        if body.len() != n * PIXEL_BYTES {
            return Err(bad(format!(
                "expected {} bytes of pixel sums for {width}x{height} pixels, found {}",
                n * PIXEL_BYTES,
                body.len()
            )));
        }
        let mut p = Self::try_new((width, height), spp, (0, 0), key)?;
        p.ranges = ranges;
        p.dropped = int("dropped", u64::MAX)?;
        for (k, px) in body.chunks_exact(PIXEL_BYTES).enumerate() {
            let f =
                |i: usize| f64::from_le_bytes(px[8 * i..8 * i + 8].try_into().expect("8 bytes"));
            p.sum[k] = [f(0), f(1), f(2)];
            p.sum2[k] = [f(3), f(4), f(5)];
            p.count[k] = u32::from_le_bytes(px[48..52].try_into().expect("4 bytes"));
            let samples: u32 = p.ranges.iter().map(|r| r.1 - r.0).sum();
            let (m, v) = mean_and_variance(p.sum[k], p.sum2[k], p.count[k]);
            let sane = (0..6).all(|i| f(i).is_finite())
                && p.sum2[k].iter().all(|&x| x >= 0.0)
                && p.count[k] <= samples
                && m.is_finite()
                && v.is_finite();
            if !sane {
                return Err(bad(format!(
                    "pixel {k}: expected finite sums of at most {samples} samples whose mean and variance are finite"
                )));
            }
        }
        Ok(p)
    }
}

/// A pixel's mean and the variance of that mean from the sums of its `n` finite samples
/// (what a render writes; zero variance below two samples).
pub fn mean_and_variance(sum: [f64; 3], sum2: [f64; 3], n: u32) -> (Rgb, Rgb) {
    let nf = n.max(1) as f64;
    let m = sum.map(|s| s / nf);
    let v: [f64; 3] = std::array::from_fn(|k| {
        if n > 1 {
            ((sum2[k] - sum[k] * m[k]) / (nf - 1.0)).max(0.0) / nf
        } else {
            0.0
        }
    });
    (
        Rgb::new(m[0] as f32, m[1] as f32, m[2] as f32),
        Rgb::new(v[0] as f32, v[1] as f32, v[2] as f32),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::{RenderOptions, render, render_samples};
    use crate::scene::{LoadOptions, from_value};

    fn scene(spp: u32) -> crate::scene::Scene {
        let v = json!({
            "camera": {"type": "perspective", "fov": 40, "origin": [0, 0, 4], "target": [0, 0, 0]},
            "film": {"width": 24, "height": 20},
            "sampler": {"spp": spp, "seed": 7},
            "shapes": [{"type": "sphere", "material": {"type": "ward", "diffuse": 0.3, "specular": 0.2, "alpha": 0.1}}],
            "lights": [{"type": "envmap", "file": "builtin:studio"}]
        });
        from_value(
            &v,
            "s.json",
            std::path::Path::new("."),
            &LoadOptions::with_builtins(),
        )
        .unwrap()
    }

    /// Parts of disjoint ranges, merged in any order and through their bytes, give the
    /// whole render: one part over every sample bit for bit, several within one f32 step
    /// per pixel (and mostly equal).
    #[test]
    fn parts_add_up_to_the_whole_render() {
        let s = scene(37);
        let opts = RenderOptions::default();
        let (whole, _) = render(&s, &opts).unwrap();
        let (all, _) = render_samples(&s, (0, 37), &opts).unwrap();
        let img = all.image().unwrap();
        assert!(img.pixels == whole.pixels && img.variance == whole.variance);
        let parts: Vec<PartialRender> = [(20, 37), (0, 5), (5, 20)]
            .iter()
            .map(|&r| {
                let p = render_samples(&s, r, &opts).unwrap().0;
                PartialRender::from_bytes(&p.to_bytes(), "part").unwrap()
            })
            .collect();
        let merged = PartialRender::merge(parts.clone()).unwrap();
        assert!(merged.is_complete());
        let img = merged.image().unwrap();
        let mut equal = 0;
        for (a, b) in img.pixels.iter().zip(&whole.pixels) {
            for (x, y) in a.to_array().iter().zip(b.to_array()) {
                assert!((x - y).abs() <= 1e-6 * y.abs().max(1e-30), "{x} vs {y}");
                equal += (x == &y) as usize;
            }
        }
        assert!(equal * 10 >= 9 * 3 * img.pixels.len(), "{equal}");
        // Incomplete, overlapping, or of another scene: refused.
        let e = PartialRender::merge(parts[..2].to_vec())
            .unwrap()
            .image()
            .unwrap_err();
        assert!(e.to_string().contains("expected every sample"), "{e}");
        let e = PartialRender::merge(vec![parts[1].clone(), parts[1].clone()]).unwrap_err();
        assert!(e.to_string().contains("overlap"), "{e}");
        let other = render_samples(&scene(38), (0, 5), &opts).unwrap().0;
        let e = PartialRender::merge(vec![parts[0].clone(), other]).unwrap_err();
        assert!(e.to_string().contains("key"), "{e}");
        assert!(render_samples(&s, (5, 5), &opts).is_err());
        assert!(render_samples(&s, (0, 38), &opts).is_err());
        let e =
            PartialRender::from_bytes(b"lobe-partial-render 1\n{}\n", "p.lobepart").unwrap_err();
        assert!(e.to_string().starts_with("p.lobepart"), "{e}");
    }
}
