//! Read-scaling benchmark (a program, not a timed test): `cargo bench --bench read_scaling`.
//!
//! Issue 14, defect 7: reading many `<Piece>`s or many arrays was quadratic (2,000 / 4,000 /
//! 8,000 / 16,000 one-triangle pieces took 0.25 / 2.2 / 19 / 69 s; 50,000 point arrays 6–17
//! s). This program writes ASCII VTU files into a temporary folder and times `read_vtu` (the
//! whole read: bytes, start check, XML, decoding, merging of pieces) and `mesh::build`, best
//! of five runs:
//!
//! - 2,000 … 16,000 one-triangle pieces (one point array each), against one piece holding the
//!   same 16,000 triangles and against one piece of the same file size;
//! - 12,500 … 50,000 point arrays of one triangle, against one array in one piece of the same
//!   file size.
//!
//! "ratio" is the time of the many-piece (many-array) file over that of the single-piece
//! (single-array) file of the same size: linear reading keeps it flat as the count grows
//! (the issue asks for at most 2).

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use fosls::{mesh, read};

const HEAD: &str = "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" \
                    byte_order=\"LittleEndian\">\n<UnstructuredGrid>\n";

/// One piece of `tris` disjoint triangles starting at x = `x0`, with `arrays` scalar point
/// arrays.
fn piece(out: &mut String, x0: f64, tris: usize, arrays: usize) {
    let _ = write!(
        out,
        "<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{tris}\"><Points><DataArray \
         type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">",
        3 * tris
    );
    for t in 0..tris {
        let x = x0 + 2.0 * t as f64;
        let _ = write!(out, "{x} 0 0 {} 0 0 {x} 1 0 ", x + 1.0);
    }
    out.push_str("</DataArray></Points><Cells><DataArray type=\"Int32\" Name=\"connectivity\" format=\"ascii\">");
    for k in 0..3 * tris {
        let _ = write!(out, "{k} ");
    }
    out.push_str("</DataArray><DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">");
    for t in 0..tris {
        let _ = write!(out, "{} ", 3 * (t + 1));
    }
    out.push_str("</DataArray><DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">");
    for _ in 0..tris {
        out.push_str("5 ");
    }
    out.push_str("</DataArray></Cells><PointData>");
    for a in 0..arrays {
        let _ = write!(
            out,
            "<DataArray type=\"Float64\" Name=\"a{a}\" format=\"ascii\">"
        );
        for k in 0..3 * tris {
            let _ = write!(out, "{} ", (k % 7) + 1);
        }
        out.push_str("</DataArray>\n");
    }
    out.push_str("</PointData></Piece>\n");
}

/// A file of `pieces` pieces of `tris` triangles with `arrays` arrays each.
fn file(pieces: usize, tris: usize, arrays: usize) -> String {
    let mut s = String::from(HEAD);
    for p in 0..pieces {
        piece(&mut s, 2.0 * (p * tris) as f64, tris, arrays);
    }
    s.push_str("</UnstructuredGrid></VTKFile>\n");
    s
}

/// Best of five: (read_vtu seconds, mesh::build seconds).
fn time(path: &Path) -> (f64, f64) {
    let (mut read_best, mut mesh_best) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..5 {
        let t0 = Instant::now();
        let vtu = read::vtu::read_vtu(path).unwrap();
        let t1 = Instant::now();
        let data = mesh::build(vtu).unwrap();
        let t2 = Instant::now();
        std::hint::black_box(&data);
        read_best = read_best.min((t1 - t0).as_secs_f64());
        mesh_best = mesh_best.min((t2 - t1).as_secs_f64());
    }
    (read_best, mesh_best)
}

/// Triangles of a one-piece, one-array file of about `bytes` bytes.
fn tris_for(bytes: usize) -> usize {
    let one = file(1, 1000, 1).len();
    (bytes * 1000).div_ceil(one).max(1)
}

fn row(label: &str, dir: &Path, text: &str, reference: Option<(f64, usize)>) -> (f64, usize) {
    let path = dir.join("f.vtu");
    std::fs::write(&path, text).unwrap();
    let (r, m) = time(&path);
    let mb = text.len() as f64 / 1e6;
    let ratio = reference.map_or(String::from("-"), |(t, b)| {
        // The reference scaled to this file's size.
        format!("{:.2}", r / (t * text.len() as f64 / b as f64))
    });
    println!(
        "{label:<40} {mb:>7.2} MB  read {:>8.1} ms  ({:>6.1} MB/s)  mesh {:>7.1} ms  ratio {ratio}",
        r * 1e3,
        mb / r,
        m * 1e3
    );
    (r, text.len())
}

fn main() {
    let dir = tempfile::tempdir().unwrap();
    println!("read_vtu and mesh::build, best of 5 (release build recommended)\n");
    let big = file(16_000, 1, 1);
    let same_size = row(
        "one piece, same size as 16,000 pieces",
        dir.path(),
        &file(1, tris_for(big.len()), 1),
        None,
    );
    row(
        "one piece, the same 16,000 triangles",
        dir.path(),
        &file(1, 16_000, 1),
        None,
    );
    for n in [2_000, 4_000, 8_000, 16_000] {
        row(
            &format!("{n} one-triangle pieces"),
            dir.path(),
            &file(n, 1, 1),
            Some(same_size),
        );
    }
    println!();
    let many = file(1, 1, 50_000);
    let same_size = row(
        "one array, same size as 50,000 arrays",
        dir.path(),
        &file(1, tris_for(many.len()), 1),
        None,
    );
    for n in [12_500, 25_000, 50_000] {
        row(
            &format!("{n} point arrays"),
            dir.path(),
            &file(1, 1, n),
            Some(same_size),
        );
    }
}
