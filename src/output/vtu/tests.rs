//! Tests of the VTK XML writer and reader.

use super::read::{attribute, find_start_tag, raw_arrays_in, RawArray};
use super::*;
use proptest::prelude::*;

/// Awkward values: signed zeros, extremes, subnormals, non-representable decimals,
/// infinities.
const AWKWARD: [f64; 12] = [
    -0.0,
    0.0,
    1e-300,
    1e300,
    -1e300,
    0.1,
    1.0 / 3.0,
    -2.0 / 3.0,
    f64::MIN_POSITIVE / 3.0,
    f64::MAX,
    f64::INFINITY,
    f64::NEG_INFINITY,
];

fn bits(values: &[f64]) -> Vec<u64> {
    values.iter().map(|v| v.to_bits()).collect()
}

/// Every opened tag is closed in order, `<?...?>` declarations skipped, `<.../>`
/// self-closing; exactly one root element; no text outside the root.
fn assert_balanced(text: &str) {
    let mut stack: Vec<&str> = Vec::new();
    let mut roots = 0;
    let mut rest = text;
    while let Some(lt) = rest.find('<') {
        if stack.is_empty() {
            assert!(
                rest[..lt].trim().is_empty(),
                "text outside the root element"
            );
        }
        rest = &rest[lt..];
        if rest.starts_with("<?") {
            let end = rest.find("?>").expect("unterminated declaration");
            rest = &rest[end + 2..];
            continue;
        }
        let gt = rest.find('>').expect("unterminated tag");
        let tag = &rest[1..gt];
        assert!(!tag.contains('<'), "`<` inside tag {tag}");
        if let Some(name) = tag.strip_prefix('/') {
            assert_eq!(stack.pop(), Some(name.trim()), "mismatched </{name}>");
        } else {
            let name = tag
                .split(|c: char| c.is_ascii_whitespace() || c == '/')
                .next()
                .unwrap();
            assert!(!name.is_empty(), "empty tag name");
            if stack.is_empty() {
                roots += 1;
            }
            if !tag.ends_with('/') {
                stack.push(name);
            }
        }
        rest = &rest[gt + 1..];
    }
    assert!(stack.is_empty(), "unclosed tags {stack:?}");
    assert!(rest.trim().is_empty(), "text after the root element");
    assert_eq!(roots, 1, "expected exactly one root element");
}

/// Decoded `Int64` / `UInt8` cell arrays of a file.
fn cells(text: &str) -> (Vec<i64>, Vec<i64>, Vec<u8>) {
    let arrays = raw_arrays_in(text, "Cells").unwrap();
    assert_eq!(arrays.len(), 3);
    let ints = |a: &RawArray| -> Vec<i64> {
        assert_eq!(a.type_name, "Int64");
        a.bytes
            .chunks_exact(8)
            .map(|c| i64::from_le_bytes(c.try_into().unwrap()))
            .collect()
    };
    assert_eq!(arrays[0].name, "connectivity");
    assert_eq!(arrays[1].name, "offsets");
    assert_eq!(arrays[2].name, "types");
    assert_eq!(arrays[2].type_name, "UInt8");
    (ints(&arrays[0]), ints(&arrays[1]), arrays[2].bytes.clone())
}

fn check_round_trip(dims: usize) {
    let n = AWKWARD.len();
    let coords: Vec<Vec<f64>> = (0..dims)
        .map(|a| (0..n).map(|i| AWKWARD[(i + 5 * a) % n]).collect())
        .collect();
    let coord_slices: Vec<&[f64]> = coords.iter().map(Vec::as_slice).collect();
    let mass: Vec<f64> = AWKWARD.iter().map(|v| -v).collect();
    let vel: Vec<Vec<f64>> = (0..3)
        .map(|c| (0..n).map(|i| AWKWARD[(i + c + 1) % n] * 0.7).collect())
        .collect();
    let stress: Vec<Vec<f64>> = (0..4)
        .map(|c| {
            (0..n)
                .map(|i| AWKWARD[(3 * i + c) % n] + i as f64 * 1e-17)
                .collect()
        })
        .collect();
    let arrays = [
        PointArray {
            name: "mass",
            components: vec![&mass],
        },
        PointArray {
            name: "velocity",
            components: vel.iter().map(Vec::as_slice).collect(),
        },
        PointArray {
            name: "stress <2x2> & \"more\"",
            components: stress.iter().map(Vec::as_slice).collect(),
        },
    ];
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(format!("particles_{dims}d.vtu"));
    write_vtu(&path, &coord_slices, &arrays).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert_balanced(&text);
    assert!(text.contains(
        "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">"
    ));
    assert!(text.contains(&format!("NumberOfPoints=\"{n}\" NumberOfCells=\"{n}\"")));

    let summary = read_vtu_summary(&text).unwrap();
    assert_eq!(summary.n_points, n);
    assert_eq!(summary.n_cells, n);
    let axes = coord_slices.as_slice();
    let expected_points: Vec<f64> = (0..n)
        .flat_map(|i| (0..3).map(move |a| axes.get(a).map_or(0.0, |x| x[i])))
        .collect();
    assert_eq!(bits(&summary.points), bits(&expected_points));
    assert_eq!(summary.arrays.len(), 3);
    for (array, (name, components, values)) in arrays.iter().zip(&summary.arrays) {
        assert_eq!(name, array.name);
        assert_eq!(*components, array.components.len());
        let interleaved: Vec<f64> = (0..n)
            .flat_map(|i| array.components.iter().map(move |c| c[i]))
            .collect();
        assert_eq!(bits(values), bits(&interleaved), "array {name}");
    }

    let (connectivity, offsets, types) = cells(&text);
    assert_eq!(connectivity, (0..n as i64).collect::<Vec<_>>());
    assert_eq!(offsets, (1..=n as i64).collect::<Vec<_>>());
    assert_eq!(types, vec![1u8; n]);
    // Atomic write leaves no temporary file behind.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

#[test]
fn round_trip_2d() {
    check_round_trip(2);
}

#[test]
fn round_trip_3d() {
    check_round_trip(3);
}

#[test]
fn round_trip_1d_and_nan_bits() {
    let x = [0.5, -0.0, 2.5];
    let payload_nan = f64::from_bits(0x7ff8_0000_dead_beef);
    let s = [f64::NAN, payload_nan, -f64::NAN];
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.vtu");
    let arrays = [PointArray {
        name: "s",
        components: vec![&s],
    }];
    write_vtu(&path, &[&x], &arrays).unwrap();
    let summary = read_vtu_summary(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(
        bits(&summary.points),
        bits(&[0.5, 0.0, 0.0, -0.0, 0.0, 0.0, 2.5, 0.0, 0.0])
    );
    assert_eq!(bits(&summary.arrays[0].2), bits(&s));
}

#[test]
fn larger_than_the_encoder_stage() {
    // Several stage flushes, with a byte count that is not a multiple of 3.
    let n = 1000;
    let x: Vec<f64> = (0..n).map(|i| i as f64 * 0.1).collect();
    let y: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.vtu");
    let arrays = [PointArray {
        name: "v",
        components: vec![&y, &x],
    }];
    write_vtu(&path, &[&x, &y], &arrays).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert_balanced(&text);
    let summary = read_vtu_summary(&text).unwrap();
    assert_eq!(summary.n_points, n);
    let expected: Vec<f64> = (0..n).flat_map(|i| [y[i], x[i]]).collect();
    assert_eq!(bits(&summary.arrays[0].2), bits(&expected));
    let (_, _, types) = cells(&text);
    assert_eq!(types, vec![1u8; n]);
}

#[test]
fn zero_points_writes_a_valid_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("empty.vtu");
    let empty: &[f64] = &[];
    let arrays = [PointArray {
        name: "velocity",
        components: vec![empty, empty],
    }];
    write_vtu(&path, &[empty, empty], &arrays).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert_balanced(&text);
    assert!(text.contains("NumberOfPoints=\"0\" NumberOfCells=\"0\""));
    let summary = read_vtu_summary(&text).unwrap();
    assert_eq!(
        summary,
        VtuSummary {
            n_points: 0,
            n_cells: 0,
            arrays: vec![("velocity".to_string(), 2, vec![])],
            points: vec![],
        }
    );
    let (c, o, t) = cells(&text);
    assert!(c.is_empty() && o.is_empty() && t.is_empty());
    // No arrays at all is fine too.
    write_vtu(&path, &[empty], &[]).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert_balanced(&text);
    assert!(read_vtu_summary(&text).unwrap().arrays.is_empty());
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.vtu");
    let a = [1.0, 2.0, 3.0];
    let b = [1.0, 2.0];
    let ok = PointArray {
        name: "m",
        components: vec![&a],
    };
    let cases: Vec<(Vec<&[f64]>, Vec<PointArray>)> = vec![
        (vec![], vec![]),
        (vec![&a, &a, &a, &a], vec![]),
        (vec![&a, &b], vec![]),
        (
            vec![&a],
            vec![PointArray {
                name: "m",
                components: vec![&b],
            }],
        ),
        (
            vec![&a, &a],
            vec![PointArray {
                name: "v",
                components: vec![&a, &b, &a],
            }],
        ),
        (
            vec![&a],
            vec![PointArray {
                name: "m",
                components: vec![],
            }],
        ),
        (
            vec![&a],
            vec![PointArray {
                name: "",
                components: vec![&a],
            }],
        ),
        (vec![&a], vec![ok.clone(), ok.clone()]),
    ];
    for (coords, arrays) in &cases {
        let err = write_vtu(&path, coords, arrays).unwrap_err();
        assert!(matches!(err, Error::WriteOutput { .. }), "{err}");
        assert!(err.to_string().contains("bad.vtu"), "{err}");
    }
    assert!(!path.exists());
    // A missing directory is an error too.
    let missing = dir.path().join("no/such/dir/p.vtu");
    assert!(write_vtu(&missing, &[&a], &[ok]).is_err());
    assert!(write_pvd(&dir.path().join("no/x.pvd"), &[]).is_err());
    // Bad pvd entries.
    let pvd = dir.path().join("bad.pvd");
    assert!(write_pvd(&pvd, &[(f64::NAN, "a.vtu".into())]).is_err());
    assert!(write_pvd(&pvd, &[(0.0, String::new())]).is_err());
    assert!(!pvd.exists());
}

#[test]
fn pvd_lists_every_entry_with_its_timestep() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("particles.pvd");
    let times = [0.0, 1e-9, 0.1, 1.0 / 3.0, 2.5, 1e20];
    let entries: Vec<(f64, String)> = times
        .iter()
        .enumerate()
        .map(|(k, &t)| (t, format!("particles_{k:04}.vtu")))
        .collect();
    write_pvd(&path, &entries).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert_balanced(&text);
    assert!(text.contains("<VTKFile type=\"Collection\""));
    let mut from = 0;
    let mut found = Vec::new();
    while let Some((_, tag, end)) = find_start_tag(&text, from, "DataSet") {
        assert!(tag.ends_with("/>"));
        assert_eq!(attribute(tag, "group").as_deref(), Some(""));
        assert_eq!(attribute(tag, "part").as_deref(), Some("0"));
        let t: f64 = attribute(tag, "timestep").unwrap().parse().unwrap();
        found.push((t, attribute(tag, "file").unwrap()));
        from = end;
    }
    assert_eq!(found.len(), entries.len());
    for ((t, file), (t0, file0)) in found.iter().zip(&entries) {
        assert_eq!(t.to_bits(), t0.to_bits());
        assert_eq!(file, file0);
    }
    // Empty collection is valid.
    write_pvd(&path, &[]).unwrap();
    assert_balanced(&std::fs::read_to_string(&path).unwrap());
}

#[test]
fn base64_rfc4648_vectors() {
    let vectors = [
        ("", ""),
        ("f", "Zg=="),
        ("fo", "Zm8="),
        ("foo", "Zm9v"),
        ("foob", "Zm9vYg=="),
        ("fooba", "Zm9vYmE="),
        ("foobar", "Zm9vYmFy"),
    ];
    for (plain, encoded) in vectors {
        assert_eq!(encode_base64(plain.as_bytes()), encoded);
        assert_eq!(decode_base64(encoded).unwrap(), plain.as_bytes());
    }
    assert_eq!(encode_base64(&[0xfb, 0xff, 0xbf]), "+/+/");
}

#[test]
fn base64_rejects_malformed_text() {
    for bad in [
        "Zm9", "Zg=", "Z===", "=g==", "Zg==Zg==", "Zm=v", "Zm9v!A==", "Zm9vYg",
    ] {
        assert_eq!(decode_base64(bad), None, "{bad}");
    }
    assert_eq!(decode_base64(" Zm\n9v\tYg== \n").unwrap(), b"foob");
}

#[test]
fn reader_rejects_inconsistent_files() {
    assert_eq!(read_vtu_summary(""), None);
    assert_eq!(read_vtu_summary("<VTKFile>"), None);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.vtu");
    let x = [1.0, 2.0];
    write_vtu(&path, &[&x], &[]).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(read_vtu_summary(&text).is_some());
    let wrong_count = text.replace("NumberOfPoints=\"2\"", "NumberOfPoints=\"3\"");
    assert_eq!(read_vtu_summary(&wrong_count), None);
}

proptest! {
    #[test]
    fn base64_round_trips(bytes in proptest::collection::vec(any::<u8>(), 0..5000)) {
        let encoded = encode_base64(&bytes);
        prop_assert_eq!(encoded.len(), bytes.len().div_ceil(3) * 4);
        prop_assert_eq!(decode_base64(&encoded), Some(bytes));
    }

    #[test]
    fn streaming_encoder_matches_one_shot(
        bytes in proptest::collection::vec(any::<u8>(), 0..8000),
        cuts in proptest::collection::vec(0usize..8000, 0..12),
    ) {
        let mut cuts: Vec<usize> = cuts.into_iter().map(|c| c.min(bytes.len())).collect();
        cuts.sort_unstable();
        let mut out = Vec::new();
        let mut encoder = Base64Encoder::new(&mut out);
        let mut start = 0;
        for cut in cuts.into_iter().chain([bytes.len()]) {
            encoder.push(&bytes[start..cut]);
            start = cut;
        }
        encoder.finish();
        prop_assert_eq!(String::from_utf8(out).unwrap(), encode_base64(&bytes));
    }
}
