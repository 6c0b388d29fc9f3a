//! Reading files from anywhere (issue 14, defects 7, 9, 10, 12, 16, 17): time linear in the
//! number of pieces and arrays, a large file that is not VTK XML refused after a few
//! kilobytes, a comment may mention `<AppendedData`, UInt64 values reported in their type,
//! values in messages cut and escaped, and names XML cannot hold refused by the writer. Each
//! case runs the real binary (exit status, one line).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_fosls");

fn encodings(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/encodings")
        .join(name)
}

fn inspect(path: &Path) -> Output {
    Command::new(BIN)
        .arg("inspect")
        .arg(path)
        .arg("--quiet")
        .output()
        .unwrap()
}

/// Exit status 2 and one line; returns it after `error: PATH: `.
fn refused(out: &Output, path: &Path) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    let prefix = format!("error: {}: ", path.display());
    stderr
        .strip_prefix(&prefix)
        .unwrap_or_else(|| panic!("{stderr}"))
        .trim_end()
        .to_string()
}

const HEAD: &str = "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" \
                    byte_order=\"LittleEndian\">\n<UnstructuredGrid>\n";
const TAIL: &str = "</UnstructuredGrid></VTKFile>\n";

/// One triangle as a piece, with one point array.
fn piece(i: usize) -> String {
    let x = 2.0 * i as f64;
    format!(
        "<Piece NumberOfPoints=\"3\" NumberOfCells=\"1\"><Points><DataArray type=\"Float64\" \
         NumberOfComponents=\"3\" format=\"ascii\">{x} 0 0 {} 0 0 {x} 1 0</DataArray></Points>\
         <Cells><DataArray type=\"Int32\" Name=\"connectivity\" format=\"ascii\">0 1 2</DataArray>\
         <DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">3</DataArray><DataArray \
         type=\"UInt8\" Name=\"types\" format=\"ascii\">5</DataArray></Cells><PointData>\
         <DataArray type=\"Float64\" Name=\"s\" format=\"ascii\">1 2 3</DataArray></PointData>\
         </Piece>\n",
        x + 1.0
    )
}

fn pieces(n: usize) -> String {
    let mut s = String::from(HEAD);
    for i in 0..n {
        s.push_str(&piece(i));
    }
    s.push_str(TAIL);
    s
}

/// One triangle with `n` point arrays.
fn arrays(n: usize) -> String {
    let mut s = String::from(HEAD);
    s.push_str(
        "<Piece NumberOfPoints=\"3\" NumberOfCells=\"1\"><Points><DataArray type=\"Float64\" \
         NumberOfComponents=\"3\" format=\"ascii\">0 0 0 1 0 0 0 1 0</DataArray></Points><Cells>\
         <DataArray type=\"Int32\" Name=\"connectivity\" format=\"ascii\">0 1 2</DataArray>\
         <DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">3</DataArray><DataArray \
         type=\"UInt8\" Name=\"types\" format=\"ascii\">5</DataArray></Cells><PointData>\n",
    );
    for i in 0..n {
        s.push_str(&format!(
            "<DataArray type=\"Float64\" Name=\"a{i}\" format=\"ascii\">1 2 3</DataArray>\n"
        ));
    }
    s.push_str("</PointData></Piece>");
    s.push_str(TAIL);
    s
}

/// Seconds `fosls inspect` takes on `text` (best of two), checking it succeeds.
fn seconds(dir: &Path, name: &str, text: &str) -> f64 {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    let mut best = f64::INFINITY;
    for _ in 0..2 {
        let start = Instant::now();
        let out = Command::new(BIN)
            .arg("inspect")
            .arg(&path)
            .args(["--quiet", "--timeout", "300"])
            .output()
            .unwrap();
        best = best.min(start.elapsed().as_secs_f64());
        assert_eq!(out.status.code(), Some(0), "{name}: {out:?}");
    }
    best
}

/// Defect 7: 16,000 one-triangle pieces were read in time growing with the square of their
/// number (0.25 s for 2,000, 69 s for 16,000). Now 16 times the pieces take at most 5 × 16
/// times as long (linear extrapolation with a factor 5 of slack).
#[test]
fn many_pieces_are_read_in_linear_time() {
    let dir = tempfile::tempdir().unwrap();
    let small = seconds(dir.path(), "p1000.vtu", &pieces(1_000));
    let large = seconds(dir.path(), "p16000.vtu", &pieces(16_000));
    eprintln!("1,000 pieces: {small:.3} s; 16,000 pieces: {large:.3} s");
    assert!(
        large <= 5.0 * 16.0 * small,
        "16,000 pieces took {large:.3} s, 1,000 took {small:.3} s"
    );
}

/// Defect 7: 50,000 point arrays (6–17 s before).
#[test]
fn many_arrays_are_read_in_linear_time() {
    let dir = tempfile::tempdir().unwrap();
    let small = seconds(dir.path(), "a3125.vtu", &arrays(3_125));
    let large = seconds(dir.path(), "a50000.vtu", &arrays(50_000));
    eprintln!("3,125 arrays: {small:.3} s; 50,000 arrays: {large:.3} s");
    assert!(
        large <= 5.0 * 16.0 * small,
        "50,000 arrays took {large:.3} s, 3,125 took {small:.3} s"
    );
}

/// Defect 12: a 2 GiB file of zeros was read whole (11 s, 2.1 GB) before "not a VTK XML file",
/// and aborted (exit 134) under a 1 GiB address-space limit. Now its first bytes refuse it.
#[test]
fn a_large_file_of_zeros_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("zeros.vtu");
    let f = std::fs::File::create(&path).unwrap();
    f.set_len(2 << 30).unwrap(); // sparse: no disk space
    drop(f);
    let start = Instant::now();
    let out = inspect(&path);
    let took = start.elapsed();
    assert_eq!(
        refused(&out, &path),
        "file: is not a VTK XML file (byte 0 is 0x00, where the XML declaration or <VTKFile> \
         should start)"
    );
    assert!(took < Duration::from_secs(3), "took {took:?}");
    let limited = Command::new("/bin/sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v 1048576; exec '{BIN}' inspect '{}' --quiet",
            path.display()
        ))
        .output()
        .unwrap();
    assert_eq!(limited.status.code(), Some(2), "{limited:?}");

    // A plausible start and then 2 GiB: refused before allocating under the same limit.
    let header = std::fs::read(encodings("p2_vtk_appended_raw_zlib.vtu")).unwrap();
    let big = dir.path().join("big.vtu");
    std::fs::write(&big, &header[..8192]).unwrap();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&big)
        .unwrap()
        .set_len(2 << 30)
        .unwrap();
    let limited = Command::new("/bin/sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v 1048576; exec '{BIN}' inspect '{}' --quiet",
            big.display()
        ))
        .output()
        .unwrap();
    assert_eq!(
        refused(&limited, &big),
        "file: is 2147483648 bytes, more than fosls can allocate to read it"
    );
    // Other starts that cannot be VTK XML.
    for (start, problem) in [
        (
            &b"\xff\xfe<\0V\0"[..],
            "file: is UTF-16 text; fosls reads VTK XML files in UTF-8",
        ),
        (
            b"<?xml version=\"1.0\"?>\n<!-- a comment -->\n<html>",
            "root element: is <html>, not <VTKFile>: not a VTK XML file",
        ),
        (
            b"\x89PNG\r\n",
            "file: is not a VTK XML file (byte 0 is 0x89, where the XML declaration or \
             <VTKFile> should start)",
        ),
    ] {
        let p = dir.path().join("start.vtu");
        let mut bytes = start.to_vec();
        bytes.resize(1 << 20, b' ');
        std::fs::write(&p, &bytes).unwrap();
        assert_eq!(refused(&inspect(&p), &p), problem);
    }
    // 1 MiB of whitespace and no element: refused at 1 MiB, not read to the end.
    let p = dir.path().join("blank.vtu");
    let f = std::fs::File::create(&p).unwrap();
    drop(f);
    std::fs::write(&p, vec![b' '; 3 << 20]).unwrap();
    assert_eq!(
        refused(&inspect(&p), &p),
        "file: is not a VTK XML file (no <VTKFile> element in its first 1048576 bytes)"
    );
}

/// Defect 16: a comment (or CDATA) mentioning `<AppendedData` is XML like any other.
#[test]
fn a_comment_may_mention_appended_data() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = std::fs::read(encodings("p2_vtk_appended_raw_zlib.vtu")).unwrap();
    let text = String::from_utf8_lossy(&bytes);
    let root = text.find("<UnstructuredGrid>").unwrap();
    let mut with = bytes[..root].to_vec();
    with.extend_from_slice(b"<!-- <AppendedData encoding=\"raw\">_ is below -->\n");
    with.extend_from_slice(&bytes[root..]);
    let path = dir.path().join("comment.vtu");
    std::fs::write(&path, &with).unwrap();
    let out = inspect(&path);
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    let plain = fosls::read::vtu::parse_vtu(&path, &bytes).unwrap();
    let read = fosls::read::vtu::read_vtu(&path).unwrap();
    assert_eq!(read.points, plain.points);
    assert_eq!(read.point_data[0].values, plain.point_data[0].values);
}

fn triangle_with(conn: &str, offsets: &str) -> String {
    format!(
        "{HEAD}<Piece NumberOfPoints=\"3\" NumberOfCells=\"1\"><Points><DataArray \
         type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">0 0 0 1 0 0 0 1 0</DataArray>\
         </Points><Cells>{conn}{offsets}<DataArray type=\"UInt8\" Name=\"types\" \
         format=\"ascii\">5</DataArray></Cells></Piece>{TAIL}"
    )
}

/// Defect 17: UInt64 2⁶⁴ − 1 was reported as point -9223372036854775808.
#[test]
fn uint64_values_are_reported_in_their_type() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("u64.vtu");
    let offsets = "<DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">3</DataArray>";
    let ascii = "<DataArray type=\"UInt64\" Name=\"connectivity\" format=\"ascii\">0 1 \
                 18446744073709551615</DataArray>";
    // The same in binary: UInt32 byte count, then three little-endian UInt64.
    use base64::Engine;
    let mut raw = 24u32.to_le_bytes().to_vec();
    for v in [0u64, 1, u64::MAX] {
        raw.extend_from_slice(&v.to_le_bytes());
    }
    let binary = format!(
        "<DataArray type=\"UInt64\" Name=\"connectivity\" format=\"binary\">{}</DataArray>",
        base64::engine::general_purpose::STANDARD.encode(&raw)
    );
    for conn in [ascii.to_string(), binary] {
        std::fs::write(&path, triangle_with(&conn, offsets)).unwrap();
        assert_eq!(
            refused(&inspect(&path), &path),
            "Cells array \"connectivity\": entry 2 refers to point 18446744073709551615, but \
             the piece has 3 points"
        );
    }
    let conn = "<DataArray type=\"Int32\" Name=\"connectivity\" format=\"ascii\">0 1 2</DataArray>";
    let offsets = "<DataArray type=\"UInt64\" Name=\"offsets\" format=\"ascii\">18446744073709551615\
         </DataArray>";
    std::fs::write(&path, triangle_with(conn, offsets)).unwrap();
    assert_eq!(
        refused(&inspect(&path), &path),
        "Cells array \"offsets\": offset 18446744073709551615 of cell 0 is past the end of the \
         connectivity (connectivity has 3 entries)"
    );
}

/// Defect 9: a 1 MB token gave a 1 MB error line; ESC, BEL and NUL reached the terminal raw.
#[test]
fn values_in_messages_are_cut_and_escaped() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("long.vtu");
    let token = "1".repeat(1 << 20);
    let text = pieces(1).replace(
        "NumberOfPoints=\"3\"",
        &format!("NumberOfPoints=\"{token}\""),
    );
    std::fs::write(&path, text).unwrap();
    let line = refused(&inspect(&path), &path);
    assert_eq!(
        line,
        format!(
            "Piece 0 NumberOfPoints: \"{}…\" (1048576 characters) is not a non-negative integer",
            "1".repeat(200)
        )
    );
    let path = dir.path().join("controls.vtu");
    let text = pieces(1).replacen(
        "type=\"UnstructuredGrid\"",
        "type=\"Un\u{1b}[31mstruct\u{7}ured\0Grid\"",
        1,
    );
    std::fs::write(&path, text).unwrap();
    let out = inspect(&path);
    assert!(
        !out.stderr[..out.stderr.len() - 1].iter().any(|&b| b < 0x20),
        "{:?}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(
        refused(&out, &path),
        "<VTKFile>: type is \"Un\\x1b[31mstruct\\x07ured\\0Grid\"; fosls reads \
         UnstructuredGrid (.vtu) files"
    );
    // A 1 MB unknown name in a scene expression: cut too (by the binary's line check).
    let scene = dir.path().join("s.toml");
    let base = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/exact_p2_energy/scene.toml"),
    )
    .unwrap();
    std::fs::write(
        &scene,
        base.replacen(
            "\"-29.261363636363637\"",
            &format!("\"{}\"", "q".repeat(1 << 20)),
            1,
        ),
    )
    .unwrap();
    let out = Command::new(BIN)
        .arg("estimate")
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/exact_p2_energy/solution.vtu"))
        .arg("--scene")
        .arg(&scene)
        .arg("--quiet")
        .output()
        .unwrap();
    let line = refused(&out, &scene);
    assert!(line.len() < 400, "{} characters", line.len());
    assert!(line.contains("(1048576 characters)"), "{line}");
    // Text reports escape names from the file too.
    let path = dir.path().join("name.vtu");
    std::fs::write(&path, pieces(1).replace("Name=\"s\"", "Name=\"a\u{1b}b\"")).unwrap();
    let out = Command::new(BIN)
        .arg("inspect")
        .arg(&path)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0));
    assert!(!out.stdout.contains(&0x1b));
    assert!(String::from_utf8_lossy(&out.stdout).contains("\"a\\x1bb\""));
}

/// Defect 10: names with a control character were written raw, and expat refused the file.
#[test]
fn names_xml_cannot_hold_are_refused_by_the_writer() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("name.vtu");
    let out_vtu = dir.path().join("out.vtu");
    for name in ["a\u{1}b", "a&#1;b", "a&#27;b"] {
        std::fs::write(
            &path,
            pieces(1).replace("Name=\"s\"", &format!("Name=\"{name}\"")),
        )
        .unwrap();
        let out = Command::new(BIN)
            .arg("convert")
            .arg(&path)
            .arg(&out_vtu)
            .output()
            .unwrap();
        let c = if name.contains("27") { "1B" } else { "01" };
        let shown = if name.contains("27") {
            "a\\x1bb"
        } else {
            "a\\x01b"
        };
        assert_eq!(
            refused(&out, &out_vtu),
            format!(
                "point array \"{shown}\": its name holds the control character U+00{c}, which \
                 XML 1.0 cannot represent (VTK and meshio would refuse the file); rename the \
                 array"
            )
        );
        assert!(!out_vtu.exists());
    }
    // estimate --output copies the file's point arrays: refused the same way, no file left.
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/exact_p2_energy");
    let bytes = std::fs::read(fixture.join("solution.vtu")).unwrap();
    let mut file = fosls::read::vtu::parse_vtu(Path::new("x.vtu"), &bytes).unwrap();
    // Written with a placeholder, then the raw control character put in its place.
    file.point_data[0].name.push_str("@@@");
    let bytes_out = fosls::write::to_bytes(&file, fosls::write::Placement::Inline);
    let at = bytes_out.windows(3).position(|w| w == b"@@@").unwrap();
    let mut raw = bytes_out[..at].to_vec();
    raw.push(1);
    raw.extend_from_slice(&bytes_out[at + 3..]);
    file.point_data[0].name = file.point_data[0].name.replace("@@@", "\u{1}");
    let bad = dir.path().join("bad.vtu");
    std::fs::write(&bad, raw).unwrap();
    let scene = fixture.join("scene.toml");
    let fields = std::fs::read_to_string(&scene).unwrap();
    let scene_copy = dir.path().join("bad.toml");
    // The renamed field is found by the scene's [fields] entry.
    let name = file.point_data[0].name.replace('\u{1}', "\\u0001");
    std::fs::write(
        &scene_copy,
        format!("{fields}\n[fields]\ndisplacement = \"{name}\"\n"),
    )
    .unwrap();
    let out = Command::new(BIN)
        .arg("estimate")
        .arg(&bad)
        .arg("--output")
        .arg(&out_vtu)
        .arg("--quiet")
        .output()
        .unwrap();
    let line = refused(&out, &out_vtu);
    assert!(line.contains("XML 1.0 cannot represent"), "{line}");
    assert!(!out_vtu.exists());
    // Markup characters and whitespace in names are escaped and read back exactly.
    let odd = "a<b> & \"c\"\td\ne";
    let mut file = fosls::read::vtu::parse_vtu(Path::new("x.vtu"), &bytes).unwrap();
    file.point_data[0].name = odd.to_string();
    for placement in [
        fosls::write::Placement::AppendedRaw,
        fosls::write::Placement::Inline,
    ] {
        let back = fosls::read::vtu::parse_vtu(
            Path::new("y.vtu"),
            &fosls::write::try_to_bytes(&file, placement).unwrap(),
        )
        .unwrap();
        assert_eq!(back.point_data[0].name, odd);
    }
}
