//! Mitsuba's tensor file format (`tensor_file`), the container of RGL measured BSDFs:
//! magic "tensor_file\0", version (1, 0), a u32 field count, then per field a u16 name
//! length, the name, a u16 dimension count, a u8 type code, a u64 absolute data offset and
//! the u64 shape; all little-endian, data dense in C order.

use crate::error::FileError;
use std::collections::HashMap;
use std::path::Path;

/// One field: type code, shape and raw bytes.
#[derive(Clone, Debug)]
pub struct Field {
    pub dtype: u8,
    pub shape: Vec<usize>,
    pub bytes: Vec<u8>,
}

/// Sizes of the type codes 1..=11 (u8, i8, u16, i16, u32, i32, u64, i64, f16, f32, f64).
fn dtype_size(code: u8) -> Option<usize> {
    Some(match code {
        1 | 2 => 1,
        3 | 4 | 9 => 2,
        5 | 6 | 10 => 4,
        7 | 8 | 11 => 8,
        _ => return None,
    })
}

#[derive(Clone, Debug)]
pub struct TensorFile {
    pub name: String,
    pub fields: HashMap<String, Field>,
}

impl TensorFile {
    pub fn read(path: &Path) -> Result<Self, FileError> {
        let shown = path.display().to_string();
        let bytes =
            crate::io::read_regular(path, crate::io::MAX_DATA_BYTES, "a tensor file (.bsdf)")?;
        Self::from_bytes(&bytes, &shown)
    }

    pub fn from_bytes(b: &[u8], name: &str) -> Result<Self, FileError> {
        let err = |m: String| FileError::new(name, m);
        if b.len() < 18 || &b[0..12] != b"tensor_file\0" {
            return Err(err(
                "does not start with \"tensor_file\"; expected an RGL/Mitsuba tensor file".into(),
            ));
        }
        if b[12] != 1 || b[13] != 0 {
            return Err(err(format!("version {}.{}; expected 1.0", b[12], b[13])));
        }
        let n = u32::from_le_bytes(b[14..18].try_into().expect("4")) as usize;
        let mut pos = 18usize;
        let need = |pos: usize, k: usize, what: &str| -> Result<(), FileError> {
            if pos + k > b.len() {
                Err(FileError::new(
                    name,
                    format!("truncated in the field table ({what}): {} bytes", b.len()),
                ))
            } else {
                Ok(())
            }
        };
        let mut fields = HashMap::new();
        for _ in 0..n.min(10_000) {
            need(pos, 2, "name length")?;
            let nl = u16::from_le_bytes(b[pos..pos + 2].try_into().expect("2")) as usize;
            pos += 2;
            need(pos, nl, "name")?;
            let fname = String::from_utf8_lossy(&b[pos..pos + nl]).to_string();
            pos += nl;
            need(pos, 11, "field header")?;
            let ndim = u16::from_le_bytes(b[pos..pos + 2].try_into().expect("2")) as usize;
            let dtype = b[pos + 2];
            let offset = u64::from_le_bytes(b[pos + 3..pos + 11].try_into().expect("8")) as usize;
            pos += 11;
            need(pos, 8 * ndim, "shape")?;
            let shape: Vec<usize> = (0..ndim)
                .map(|k| {
                    u64::from_le_bytes(b[pos + 8 * k..pos + 8 * k + 8].try_into().expect("8"))
                        as usize
                })
                .collect();
            pos += 8 * ndim;
            let size = dtype_size(dtype).ok_or_else(|| {
                err(format!(
                    "field {fname}: type code {dtype}; expected 1 to 11"
                ))
            })?;
            let count = shape
                .iter()
                .try_fold(1usize, |a, &s| a.checked_mul(s))
                .ok_or_else(|| err(format!("field {fname}: shape {shape:?} overflows")))?;
            let len = count
                .checked_mul(size)
                .ok_or_else(|| err(format!("field {fname}: too large")))?;
            if offset.checked_add(len).is_none_or(|end| end > b.len()) {
                return Err(err(format!(
                    "field {fname}: data at {offset}..{} lies past the end of the file ({} bytes): truncated",
                    offset.saturating_add(len),
                    b.len()
                )));
            }
            fields.insert(
                fname,
                Field {
                    dtype,
                    shape,
                    bytes: b[offset..offset + len].to_vec(),
                },
            );
        }
        Ok(Self {
            name: name.to_string(),
            fields,
        })
    }

    /// An f32 field with the given number of dimensions: (values, shape).
    pub fn f32s(&self, field: &str, ndim: usize) -> Result<(Vec<f32>, Vec<usize>), FileError> {
        let f = self.fields.get(field).ok_or_else(|| {
            FileError::new(
                &self.name,
                format!("no field \"{field}\"; expected one in an RGL BSDF file"),
            )
        })?;
        if f.dtype != 10 || f.shape.len() != ndim {
            return Err(FileError::new(
                &self.name,
                format!(
                    "field \"{field}\" has type code {} and shape {:?}; expected float32 with {ndim} dimensions",
                    f.dtype, f.shape
                ),
            ));
        }
        let v: Vec<f32> = f
            .bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4")))
            .collect();
        if let Some(bad) = v.iter().position(|x| !x.is_finite()) {
            return Err(FileError::new(
                &self.name,
                format!("field \"{field}\": value {bad} is not finite"),
            ));
        }
        Ok((v, f.shape.clone()))
    }
}
