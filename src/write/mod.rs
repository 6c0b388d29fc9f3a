//! VTU writer: binary, zlib-compressed, appended raw or inline base64, UInt64 headers.
//!
//! Files are written atomically: to a temporary file in the target folder, then renamed, so a
//! failure never leaves a partial file and a reader never sees one (docs/design.md §8). The rules for
//! output paths (never an input, never two outputs on one file, devices and `-` written in
//! place, nothing left behind on a timeout or a signal) are [`output`]'s; standard output and
//! standard error that never panic are [`stdio`]'s.
//!
//! Array and component names are written as XML attribute values: `&`, `"`, `<`, `>` and tab,
//! newline, carriage return are written as references; a name holding a character XML 1.0
//! cannot represent at all (the other C0 control characters, U+FFFE, U+FFFF) is refused by
//! [`try_to_bytes`] with one line naming the array.

pub mod output;
pub mod stdio;

use std::io::Write;
use std::path::Path;

pub use output::{OutputId, OutputPlan, Target, write_atomic};

use base64::Engine;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::read::vtu::VtuFile;

/// Where DataArray payloads go.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Placement {
    /// One `<AppendedData encoding="raw">` section (VTK's default).
    AppendedRaw,
    /// Base64 text inside each DataArray.
    Inline,
}

/// Uncompressed size of one zlib block (VTK's default).
const BLOCK: usize = 1 << 15;

/// One payload as `(header, blocks)`, the header in UInt64, little endian.
fn compressed_payload(raw: &[u8]) -> (Vec<u8>, Vec<u8>) {
    let blocks: Vec<Vec<u8>> = raw
        .par_chunks(BLOCK)
        .map(|b| {
            let mut z = flate2::write::ZlibEncoder::new(
                Vec::with_capacity(b.len() / 2),
                flate2::Compression::fast(),
            );
            // Writing into a Vec cannot fail.
            let _ = z.write_all(b);
            z.finish().unwrap_or_default()
        })
        .collect();
    let nblocks = blocks.len() as u64;
    let last = if raw.len().is_multiple_of(BLOCK) {
        0
    } else {
        (raw.len() % BLOCK) as u64
    };
    let mut header = Vec::with_capacity(8 * (3 + blocks.len()));
    for v in [nblocks, BLOCK as u64, last] {
        header.extend_from_slice(&v.to_le_bytes());
    }
    for b in &blocks {
        header.extend_from_slice(&(b.len() as u64).to_le_bytes());
    }
    (header, blocks.concat())
}

fn f64_bytes(v: &[f64]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn i64_bytes(v: impl Iterator<Item = i64>) -> Vec<u8> {
    v.flat_map(|x| x.to_le_bytes()).collect()
}

/// Whether XML 1.0 can hold `c` at all (production `Char`).
fn xml_char(c: char) -> bool {
    matches!(c, '\t' | '\n' | '\r') || (c >= ' ' && c != '\u{fffe}' && c != '\u{ffff}')
}

/// `s` as an XML attribute value (double quotes): markup characters and the whitespace that
/// attribute normalisation would turn into spaces are written as references; characters XML
/// cannot hold are replaced by U+FFFD (refused earlier by [`try_to_bytes`]).
fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '"' => out.push_str("&quot;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '\t' => out.push_str("&#9;"),
            '\n' => out.push_str("&#10;"),
            '\r' => out.push_str("&#13;"),
            c if !xml_char(c) => out.push('\u{fffd}'),
            c => out.push(c),
        }
    }
    out
}

/// The first name of `file` (array or component name) that XML 1.0 cannot hold, as a message.
pub fn unwritable_name(file: &VtuFile) -> Option<String> {
    for (kind, arrays) in [("point", &file.point_data), ("cell", &file.cell_data)] {
        for a in arrays.iter() {
            let names = std::iter::once(None).chain(a.component_names.iter().map(Some));
            for component in names {
                let n = component.unwrap_or(&a.name);
                if let Some(c) = n.chars().find(|&c| !xml_char(c)) {
                    let whose = match component {
                        None => "its name".to_string(),
                        Some(n) => format!("its component name {}", crate::error::quote(n)),
                    };
                    return Some(format!(
                        "{kind} array {}: {whose} holds the control character U+{:04X}, which \
                         XML 1.0 cannot represent (VTK and meshio would refuse the file); rename \
                         the array",
                        crate::error::quote(&a.name),
                        c as u32
                    ));
                }
            }
        }
    }
    None
}

/// Serialises a file to VTU bytes, refusing names XML cannot hold ([`unwritable_name`]).
pub fn try_to_bytes(file: &VtuFile, placement: Placement) -> std::result::Result<Vec<u8>, String> {
    match unwritable_name(file) {
        Some(problem) => Err(problem),
        None => Ok(to_bytes(file, placement)),
    }
}

/// Serialises a file to VTU bytes. Characters XML cannot hold in names are replaced by
/// U+FFFD; [`try_to_bytes`] refuses them instead.
pub fn to_bytes(file: &VtuFile, placement: Placement) -> Vec<u8> {
    // (xml attributes, raw little-endian data) per array, in document order.
    struct Item {
        attrs: String,
        raw: Vec<u8>,
    }
    let mut items: Vec<(&str, Item)> = Vec::new();
    let points: Vec<f64> = file.points.iter().flatten().copied().collect();
    items.push((
        "Points",
        Item {
            attrs: "type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\"".into(),
            raw: f64_bytes(&points),
        },
    ));
    items.push((
        "Cells",
        Item {
            attrs: "type=\"Int64\" Name=\"connectivity\"".into(),
            raw: i64_bytes(file.connectivity.iter().map(|&v| v as i64)),
        },
    ));
    items.push((
        "Cells",
        Item {
            attrs: "type=\"Int64\" Name=\"offsets\"".into(),
            raw: i64_bytes(file.offsets[1..].iter().map(|&v| v as i64)),
        },
    ));
    items.push((
        "Cells",
        Item {
            attrs: "type=\"UInt8\" Name=\"types\"".into(),
            raw: file.types.clone(),
        },
    ));
    for (section, arrays) in [
        ("PointData", &file.point_data),
        ("CellData", &file.cell_data),
    ] {
        for a in arrays.iter() {
            let mut attrs = if a.scalar.is_integer() {
                format!("type=\"Int64\" Name=\"{}\"", escape(&a.name))
            } else {
                format!("type=\"Float64\" Name=\"{}\"", escape(&a.name))
            };
            attrs.push_str(&format!(" NumberOfComponents=\"{}\"", a.components));
            for (i, n) in a.component_names.iter().enumerate() {
                attrs.push_str(&format!(" ComponentName{i}=\"{}\"", escape(n)));
            }
            let raw = if a.scalar.is_integer() {
                i64_bytes(a.values.iter().map(|&v| v as i64))
            } else {
                f64_bytes(&a.values)
            };
            items.push((section, Item { attrs, raw }));
        }
    }
    let payloads: Vec<(Vec<u8>, Vec<u8>)> = items
        .par_iter()
        .map(|(_, it)| compressed_payload(&it.raw))
        .collect();

    let mut xml = String::new();
    xml.push_str("<?xml version=\"1.0\"?>\n");
    xml.push_str(
        "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" \
         header_type=\"UInt64\" compressor=\"vtkZLibDataCompressor\">\n<UnstructuredGrid>\n",
    );
    xml.push_str(&format!(
        "<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n",
        file.points.len(),
        file.types.len()
    ));
    let mut appended: Vec<u8> = Vec::new();
    let mut section = "";
    let open = |xml: &mut String, s: &'static str, section: &mut &'static str| {
        if *section != s {
            if !section.is_empty() {
                xml.push_str(&format!("</{section}>\n"));
            }
            xml.push_str(&format!("<{s}>\n"));
            *section = s;
        }
    };
    for (k, (s, it)) in items.iter().enumerate() {
        let s: &'static str = match *s {
            "Points" => "Points",
            "Cells" => "Cells",
            "PointData" => "PointData",
            _ => "CellData",
        };
        open(&mut xml, s, &mut section);
        match placement {
            Placement::AppendedRaw => {
                xml.push_str(&format!(
                    "<DataArray {} format=\"appended\" offset=\"{}\"/>\n",
                    it.attrs,
                    appended.len()
                ));
                appended.extend_from_slice(&payloads[k].0);
                appended.extend_from_slice(&payloads[k].1);
            }
            Placement::Inline => {
                // Header and blocks as two base64 strings: VTK decodes the header on its own.
                let b64 = &base64::engine::general_purpose::STANDARD;
                xml.push_str(&format!("<DataArray {} format=\"binary\">\n", it.attrs));
                xml.push_str(&b64.encode(&payloads[k].0));
                xml.push_str(&b64.encode(&payloads[k].1));
                xml.push_str("\n</DataArray>\n");
            }
        }
    }
    if !section.is_empty() {
        xml.push_str(&format!("</{section}>\n"));
    }
    xml.push_str("</Piece>\n</UnstructuredGrid>\n");
    let mut out = xml.into_bytes();
    if placement == Placement::AppendedRaw {
        out.extend_from_slice(b"<AppendedData encoding=\"raw\">\n_");
        out.extend_from_slice(&appended);
        out.extend_from_slice(b"\n</AppendedData>\n");
    }
    out.extend_from_slice(b"</VTKFile>\n");
    out
}

/// Writes a VTU file atomically.
pub fn write_vtu(path: &Path, file: &VtuFile, placement: Placement) -> Result<()> {
    let bytes = try_to_bytes(file, placement)
        .map_err(|p| Error::Usage(format!("{}: {p}", path.display())))?;
    write_atomic(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::read::decode::Scalar;
    use crate::read::vtu::{DataArray, parse_vtu};

    fn sample() -> VtuFile {
        let mut f = VtuFile::from_cells(
            Path::new("w.vtu"),
            (0..50_000)
                .map(|i| [i as f64 * 0.25, (i % 7) as f64, 0.0])
                .collect(),
            &[
                (5, vec![0, 1, 2]),
                (3, vec![0, 1]),
                (22, vec![0, 1, 2, 3, 4, 5]),
            ],
        );
        f.point_data.push(DataArray {
            name: "u & v".into(),
            scalar: Scalar::Float64,
            components: 2,
            component_names: vec!["x".into(), "y".into()],
            values: (0..100_000).map(|i| (i as f64).sin()).collect(),
        });
        f.cell_data.push(DataArray {
            name: "tag".into(),
            scalar: Scalar::Int32,
            components: 1,
            component_names: vec![],
            values: vec![0., 1., -2.],
        });
        f
    }

    #[test]
    fn round_trips_bit_for_bit_in_both_placements() {
        let f = sample();
        for placement in [Placement::AppendedRaw, Placement::Inline] {
            let bytes = to_bytes(&f, placement);
            let g = parse_vtu(Path::new("w.vtu"), &bytes).unwrap();
            assert_eq!(g.points, f.points);
            assert_eq!(g.types, f.types);
            assert_eq!(g.offsets, f.offsets);
            assert_eq!(g.connectivity, f.connectivity);
            assert_eq!(g.point_data[0].name, "u & v");
            assert_eq!(g.point_data[0].component_names, vec!["x", "y"]);
            assert_eq!(
                g.point_data[0]
                    .values
                    .iter()
                    .map(|v| v.to_bits())
                    .collect::<Vec<_>>(),
                f.point_data[0]
                    .values
                    .iter()
                    .map(|v| v.to_bits())
                    .collect::<Vec<_>>()
            );
            assert_eq!(g.cell_data[0].values, vec![0., 1., -2.]);
            assert_eq!(g.cell_data[0].scalar, Scalar::Int64);
        }
    }

    #[test]
    fn atomic_write_replaces_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.vtu");
        std::fs::write(&p, b"old").unwrap();
        write_vtu(&p, &sample(), Placement::AppendedRaw).unwrap();
        assert!(std::fs::read(&p).unwrap().starts_with(b"<?xml"));
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1);
        let e = write_atomic(&dir.path().join("missing/out.vtu"), b"x").unwrap_err();
        assert!(e.to_string().contains("missing/out.vtu"), "{e}");
    }
}
