//! Which measured format a file holds, told by its content, never by its name: the binned
//! format's magic `LOBEBIN1` (docs/binned-format.md), the tensor-file magic
//! `tensor_file\0` of RGL files (Dupuy and Jakob 2018, Mitsuba's `measured` plugin), or the
//! MERL header of three int32 dimensions 90, 90, 180 (Matusik et al. 2003). A binned file
//! saved as `.binary` loads as binned, a MERL table saved as `.bin` as MERL.

use super::binned::MAGIC as BINNED_MAGIC;
use super::merl::{RES_PHI_D, RES_THETA_D, RES_THETA_H};
use crate::error::FileError;
use std::io::Read;
use std::path::Path;

const TENSOR_MAGIC: &[u8; 12] = b"tensor_file\0";

/// A measured-data format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Merl,
    Binned,
    Rgl,
}

impl Format {
    /// The material type that loads it (`{"type": ..., "file": ...}`).
    pub fn material_type(self) -> &'static str {
        match self {
            Format::Merl => "merl",
            Format::Binned => "binned",
            Format::Rgl => "rgl",
        }
    }

    /// What the format is, for messages.
    pub fn describe(self) -> &'static str {
        match self {
            Format::Merl => "a MERL table",
            Format::Binned => "binned data (LOBEBIN1)",
            Format::Rgl => "an RGL tensor file",
        }
    }

    /// The format of these first bytes of a file, if any.
    pub fn of_header(head: &[u8]) -> Option<Format> {
        if head.starts_with(BINNED_MAGIC) {
            return Some(Format::Binned);
        }
        if head.starts_with(TENSOR_MAGIC) {
            return Some(Format::Rgl);
        }
        let dim = |k: usize| {
            head.get(4 * k..4 * k + 4)
                .map(|b| i32::from_le_bytes(b.try_into().expect("4 bytes")))
        };
        let merl = [RES_THETA_H, RES_THETA_D, RES_PHI_D].map(|d| Some(d as i32));
        ([dim(0), dim(1), dim(2)] == merl).then_some(Format::Merl)
    }
}

/// The format of a file from its first bytes; an error naming the file when it is none of
/// them.
pub fn detect(path: &Path) -> Result<Format, FileError> {
    let shown = path.display().to_string();
    let (file, _) =
        crate::io::open_regular(path, u64::MAX, "a measured BRDF file (MERL, binned or RGL)")?;
    let mut head = Vec::with_capacity(12);
    file.take(12)
        .read_to_end(&mut head)
        .map_err(|e| FileError::new(&shown, format!("cannot read: {e}")))?;
    let expected = "expected a MERL table (int32 header 90 90 180), binned data (LOBEBIN1) or an RGL tensor file (tensor_file)";
    Format::of_header(&head).ok_or_else(|| {
        let found = if head.is_empty() {
            "is empty".to_string()
        } else {
            format!("unknown content (first bytes {})", printable(&head))
        };
        FileError::new(&shown, format!("{found}; {expected}"))
    })
}

/// Checks that `path` holds `expected`, naming the material type that would load it if not.
pub fn expect(path: &Path, expected: Format) -> Result<(), FileError> {
    let found = detect(path).or_else(|e| match std::fs::metadata(path) {
        // Unknown content: the reader of the expected format says what is wrong.
        Ok(m) if m.is_file() => Ok(expected),
        _ => Err(e),
    })?;
    if found != expected {
        return Err(FileError::new(
            path.display(),
            format!(
                "holds {}, not {}; load it with {{\"type\": \"{}\"}}",
                found.describe(),
                expected.describe(),
                found.material_type()
            ),
        ));
    }
    Ok(())
}

fn printable(head: &[u8]) -> String {
    head.iter()
        .map(|&b| {
            if b.is_ascii_graphic() {
                (b as char).to_string()
            } else {
                format!("\\x{b:02x}")
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_are_recognized() {
        assert_eq!(
            Format::of_header(b"LOBEBIN1\x01\0\0\0"),
            Some(Format::Binned)
        );
        assert_eq!(Format::of_header(b"tensor_file\0"), Some(Format::Rgl));
        let mut merl = Vec::new();
        for d in [90i32, 90, 180] {
            merl.extend_from_slice(&d.to_le_bytes());
        }
        assert_eq!(Format::of_header(&merl), Some(Format::Merl));
        assert_eq!(Format::of_header(b"{\"models\": 1"), None);
        assert_eq!(Format::of_header(b"LOBE"), None);
    }
}
