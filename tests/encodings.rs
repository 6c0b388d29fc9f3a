//! Every fixture encoding (fixtures/encodings, written by meshio, VTK and NGSolve through
//! `reference/encodings/make.py`) reads to the same mesh and fields as its family's canonical
//! file: bit-identical where the encoding is lossless, within the loss the harness measured
//! otherwise. Counts and ranges are checked against the harness's own reading (VTK and meshio),
//! through the real binary's JSON.

use std::path::{Path, PathBuf};
use std::process::Command;

use fosls::mesh::{self, Dataset};
use fosls::read::vtu::read_vtu;
use fosls::topology;
use serde::Deserialize;
use serde_json::Value;

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/encodings")
}

fn expected() -> Value {
    let text = std::fs::read_to_string(dir().join("expected.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn load(name: &str) -> Dataset {
    let d = mesh::build(read_vtu(&dir().join(name)).unwrap()).unwrap();
    topology::build(&d).unwrap();
    d
}

/// Largest difference relative to the largest magnitude of the canonical values.
fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()))
        .max(f64::MIN_POSITIVE);
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

/// Compares two datasets triangle by triangle: node coordinates and the point values at the
/// nodes (numbering-independent, so merged exploded meshes compare with conforming ones).
fn compare(name: &str, got: &Dataset, want: &Dataset, tol: &dyn Fn(&str) -> f64) {
    assert_eq!(got.mesh.degree, want.mesh.degree, "{name}");
    assert_eq!(got.mesh.cells.len(), want.mesh.cells.len(), "{name}");
    let gather = |d: &Dataset, f: &dyn Fn(usize) -> Vec<f64>| -> Vec<f64> {
        (0..d.mesh.cells.len())
            .flat_map(|t| {
                d.mesh
                    .nodes(t)
                    .iter()
                    .flat_map(|&n| f(n as usize))
                    .collect::<Vec<_>>()
            })
            .collect()
    };
    let coords = |d: &Dataset| gather(d, &|n| d.mesh.points[n].to_vec());
    check(name, "points", &coords(got), &coords(want), tol("points"));
    for w in &want.point_data {
        let g = got
            .point_array(&w.name)
            .unwrap_or_else(|| panic!("{name}: no point array {}", w.name));
        // Compare the first two components when one file pads vectors to three.
        let c = g.components.min(w.components);
        let vals = |d: &Dataset, a: &fosls::read::vtu::DataArray| {
            gather(d, &|n| {
                a.values[n * a.components..n * a.components + c].to_vec()
            })
        };
        let key = format!("point_data/{}", w.name);
        check(name, &key, &vals(got, g), &vals(want, w), tol(&key));
    }
    for w in &want.cell_data {
        let Some(g) = got.cell_data.iter().find(|a| a.name == w.name) else {
            continue;
        };
        let key = format!("cell_data/{}", w.name);
        check(name, &key, &g.values, &w.values, tol(&key));
    }
    assert_eq!(got.mesh.lines.len(), want.mesh.lines.len(), "{name}: lines");
    for w in &want.line_data {
        if let Some(g) = got.line_data.iter().find(|a| a.name == w.name) {
            check(name, &w.name, &g.values, &w.values, 0.0);
        }
    }
}

fn check(name: &str, what: &str, got: &[f64], want: &[f64], tol: f64) {
    if tol == 0.0 {
        let gb: Vec<u64> = got.iter().map(|v| v.to_bits()).collect();
        let wb: Vec<u64> = want.iter().map(|v| v.to_bits()).collect();
        assert!(
            gb == wb,
            "{name}: {what} not bit-identical (rel diff {:e})",
            rel_diff(got, want)
        );
    } else {
        let d = rel_diff(got, want);
        assert!(d <= tol, "{name}: {what} differs by {d:e} > {tol:e}");
    }
}

#[test]
fn every_encoding_reads_to_its_canonical_mesh_and_fields() {
    let exp = expected();
    let files = exp["files"].as_object().unwrap();
    assert!(files.len() >= 30, "only {} fixture files", files.len());
    for (name, info) in files {
        let canonical = info["canonical"].as_str().unwrap();
        let got = load(name);
        let want = load(canonical);
        let lossless = info["lossless"].as_bool().unwrap();
        let exploded = info["relation"] == "exploded";
        let measured = &info["max_rel_diff"];
        let tol = |key: &str| -> f64 {
            if exploded && key.starts_with("point_data/") {
                // Averages of copies: the summation order may differ from the harness's.
                4.0 * f64::EPSILON
            } else if lossless {
                0.0
            } else {
                let m = measured[key].as_f64().unwrap_or(0.0);
                (m * 1.01).max(f64::EPSILON)
            }
        };
        compare(name, &got, &want, &tol);
        if exploded {
            let m = got.report.merge.as_ref().expect("exploded file not merged");
            assert!(m.exploded);
            assert_eq!(
                m.points_merged as u64,
                info["merged_points"].as_u64().unwrap()
            );
            for j in &m.jumps {
                let e = &info["max_jump"][&j.array];
                let want = e["max_jump"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|v| v.as_f64().unwrap())
                    .fold(0.0f64, f64::max);
                assert!(
                    (j.max - want).abs() <= 1e-12 * e["absmax"].as_f64().unwrap(),
                    "{name}: jump of {} is {} vs {want}",
                    j.array,
                    j.max
                );
            }
        }
    }
}

#[derive(Deserialize)]
struct ArraySummary {
    name: String,
    components: usize,
    min: Vec<Option<f64>>,
    max: Vec<Option<f64>>,
    nan: usize,
}

#[derive(Deserialize)]
struct Summary {
    points_in_file: usize,
    cells_by_type: std::collections::BTreeMap<String, usize>,
    point_arrays: Vec<ArraySummary>,
    cell_arrays: Vec<ArraySummary>,
}

#[test]
fn inspect_json_agrees_with_the_harness_reading() {
    let exp = expected();
    for (name, info) in exp["files"].as_object().unwrap() {
        let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
            .args(["inspect", "--json", "-"])
            .arg(dir().join(name))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let s: Summary = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(
            s.points_in_file as u64,
            info["num_points"].as_u64().unwrap(),
            "{name}"
        );
        let mut by_type = std::collections::BTreeMap::new();
        for (k, v) in info["cells_by_type"].as_object().unwrap() {
            // "VTK_QUADRATIC_TRIANGLE (22)" → 22
            let t = k
                .rsplit('(')
                .next()
                .unwrap()
                .trim_end_matches(')')
                .to_string();
            by_type.insert(t, v.as_u64().unwrap() as usize);
        }
        let ours: std::collections::BTreeMap<String, usize> = s
            .cells_by_type
            .iter()
            .map(|(k, &v)| {
                (
                    k.rsplit('(')
                        .next()
                        .unwrap()
                        .trim_end_matches(')')
                        .to_string(),
                    v,
                )
            })
            .collect();
        assert_eq!(ours, by_type, "{name}");
        for (kind, arrays) in [
            ("point_data", &s.point_arrays),
            ("cell_data", &s.cell_arrays),
        ] {
            let want = info[kind].as_object().unwrap();
            assert_eq!(arrays.len(), want.len(), "{name}: {kind}");
            for a in arrays {
                let w = &want[&a.name];
                assert_eq!(a.components as u64, w["components"].as_u64().unwrap());
                assert_eq!(a.nan, 0);
                let scale = w["absmax"].as_f64().unwrap().max(f64::MIN_POSITIVE);
                for k in 0..a.components {
                    let (lo, hi) = (w["min"][k].as_f64().unwrap(), w["max"][k].as_f64().unwrap());
                    let (glo, ghi) = (a.min[k].unwrap(), a.max[k].unwrap());
                    assert!(
                        (glo - lo).abs() <= 1e-15 * scale && (ghi - hi).abs() <= 1e-15 * scale,
                        "{name}: {kind} {} component {k}: [{glo}, {ghi}] vs [{lo}, {hi}]",
                        a.name
                    );
                }
            }
        }
    }
}
