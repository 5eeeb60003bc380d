//! The PLY reader and writer agree with files written by real peers (plyfile, trimesh).
//! Fixtures and the arrays they hold come from tests/fixtures/ply/make_fixtures.py.

use objectsplat_core::Mesh;
use objectsplat_core::ply::{Column, Element, Format, Ply, Property, ScalarType};
use serde_json::Value;
use std::path::PathBuf;

mod common;
use common::{float_rows, floats};

fn fixture(name: &str) -> PathBuf {
    common::fixture("ply").join(name)
}

fn expected() -> Value {
    common::read_json(&fixture("expected.json"))
}

#[test]
fn plyfile_files_read_identically_in_every_format() {
    let exp = expected();
    for (name, format) in [
        ("odd_ascii.ply", Format::Ascii),
        ("odd_binary_le.ply", Format::BinaryLittleEndian),
        ("odd_binary_be.ply", Format::BinaryBigEndian),
    ] {
        let ply = Ply::read(&fixture(name)).unwrap();
        assert_eq!(ply.format, format, "{name}");
        assert_eq!(
            ply.comments,
            ["written by plyfile", "second comment"],
            "{name}"
        );
        assert_eq!(ply.obj_info, ["peer fixture"], "{name}");
        let vertex = ply.element("vertex").unwrap();
        let declared: Vec<&str> = vertex.properties.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(
            declared[..3],
            ["z", "red", "x"],
            "{name}: property order kept"
        );
        for (prop, values) in exp["vertex"].as_object().unwrap() {
            assert_eq!(
                vertex.scalar_f64(prop).unwrap(),
                floats(values),
                "{name}: vertex.{prop}"
            );
        }
        assert_eq!(vertex.column("flag").unwrap().scalar_type(), ScalarType::I8);
        assert_eq!(
            vertex.column("uint_v").unwrap().scalar_type(),
            ScalarType::U32
        );
        let face = ply.element("face").unwrap();
        // The big-endian fixture's faces carry only their list (see make_fixtures.py).
        if format != Format::BinaryBigEndian {
            assert_eq!(
                face.scalar_f64("quality").unwrap(),
                floats(&exp["face"]["quality"]),
                "{name}"
            );
            assert_eq!(face.scalar_i32("tag").unwrap(), [1, -2, 3], "{name}");
        } else {
            assert_eq!(face.properties.len(), 1, "{name}");
        }
        let idx = face.list_u32("vertex_indices").unwrap();
        let rows: Vec<Vec<f64>> = idx
            .rows()
            .map(|r| r.iter().map(|&v| v as f64).collect())
            .collect();
        assert_eq!(rows, float_rows(&exp["face"]["vertex_indices"]), "{name}");
        let w = ply.element("edge").unwrap().list::<f64>("weights").unwrap();
        let rows: Vec<Vec<f64>> = w.rows().map(<[f64]>::to_vec).collect();
        assert_eq!(rows, float_rows(&exp["edge"]["weights"]), "{name}");
    }
}

/// Rebuilds the plyfile fixture's content with our types, from the expected arrays.
fn rebuild_odd_fixture(exp: &Value, face_scalars: bool) -> Ply {
    let v = &exp["vertex"];
    let col = |name: &str, ty: ScalarType| {
        let vals = floats(&v[name]);
        let c = match ty {
            ScalarType::F32 => Column::F32(vals.iter().map(|&x| x as f32).collect()),
            ScalarType::F64 => Column::F64(vals),
            ScalarType::U8 => Column::U8(vals.iter().map(|&x| x as u8).collect()),
            ScalarType::I8 => Column::I8(vals.iter().map(|&x| x as i8).collect()),
            ScalarType::I16 => Column::I16(vals.iter().map(|&x| x as i16).collect()),
            ScalarType::U16 => Column::U16(vals.iter().map(|&x| x as u16).collect()),
            ScalarType::I32 => Column::I32(vals.iter().map(|&x| x as i32).collect()),
            ScalarType::U32 => Column::U32(vals.iter().map(|&x| x as u32).collect()),
        };
        Property::scalar(name, c)
    };
    use ScalarType::*;
    let mut vertex = Element::new("vertex", 5);
    for (name, ty) in [
        ("z", F32),
        ("red", U8),
        ("x", F64),
        ("flag", I8),
        ("y", F32),
        ("short_v", I16),
        ("ushort_v", U16),
        ("int_v", I32),
        ("uint_v", U32),
        ("green", U8),
        ("blue", U8),
    ] {
        vertex = vertex.with(col(name, ty));
    }
    let lists = |rows: Vec<Vec<f64>>| {
        let mut offsets = vec![0];
        for r in &rows {
            offsets.push(offsets.last().unwrap() + r.len());
        }
        (offsets, rows.into_iter().flatten().collect::<Vec<f64>>())
    };
    let (face_off, face_idx) = lists(float_rows(&exp["face"]["vertex_indices"]));
    let indices = Property::list(
        "vertex_indices",
        U16,
        face_off,
        Column::I32(face_idx.iter().map(|&x| x as i32).collect()),
    );
    let face = if face_scalars {
        Element::new("face", 3)
            .with(Property::scalar(
                "quality",
                Column::F64(floats(&exp["face"]["quality"])),
            ))
            .with(indices)
            .with(Property::scalar("tag", Column::I16(vec![1, -2, 3])))
    } else {
        Element::new("face", 3).with(indices)
    };
    let (edge_off, edge_w) = lists(float_rows(&exp["edge"]["weights"]));
    let edge = Element::new("edge", 3).with(Property::list(
        "weights",
        I32,
        edge_off,
        Column::F32(edge_w.iter().map(|&x| x as f32).collect()),
    ));
    Ply {
        comments: vec!["written by plyfile".into(), "second comment".into()],
        obj_info: vec!["peer fixture".into()],
        ..Ply::new(vec![vertex, face, edge])
    }
}

#[test]
fn binary_writer_output_is_byte_identical_to_plyfile() {
    for (name, format) in [
        ("odd_binary_le.ply", Format::BinaryLittleEndian),
        ("odd_binary_be.ply", Format::BinaryBigEndian),
    ] {
        let ply = rebuild_odd_fixture(&expected(), format != Format::BinaryBigEndian);
        let ours = ply.to_bytes(format).unwrap();
        let theirs = std::fs::read(fixture(name)).unwrap();
        assert!(ours == theirs, "{name}: our bytes differ from plyfile's");
    }
}

#[test]
fn ascii_writer_output_reads_back_to_the_plyfile_content() {
    let ply = rebuild_odd_fixture(&expected(), true);
    let ours = Ply::from_bytes(&ply.to_bytes(Format::Ascii).unwrap(), "ours.ply").unwrap();
    let theirs = Ply::read(&fixture("odd_ascii.ply")).unwrap();
    assert_eq!(ours, theirs);
}

#[test]
fn trimesh_meshes_load_as_meshes() {
    let exp = &expected()["trimesh"];
    let faces: Vec<[u32; 3]> = float_rows(&exp["faces"])
        .iter()
        .map(|r| [r[0] as u32, r[1] as u32, r[2] as u32])
        .collect();
    let colors: Vec<[u8; 3]> = float_rows(&exp["colors"])
        .iter()
        .map(|r| [r[0] as u8, r[1] as u8, r[2] as u8])
        .collect();
    let positions = float_rows(&exp["positions"]);
    for (name, printed_decimals) in [("trimesh_binary.ply", None), ("trimesh_ascii.ply", Some(8))] {
        let mesh = Mesh::read_ply(&fixture(name)).unwrap();
        assert_eq!(mesh.faces, faces, "{name}");
        assert_eq!(mesh.colors.as_ref().unwrap(), &colors, "{name}");
        assert!(mesh.object_ids.is_none());
        assert_eq!(mesh.positions.len(), positions.len());
        for (got, want) in mesh.positions.iter().zip(&positions) {
            for k in 0..3 {
                // Binary floats are exact; trimesh's ASCII exporter prints a fixed number of
                // decimals, so allow half a unit of the last decimal plus f32 rounding.
                let tolerance = match printed_decimals {
                    None => 0.0,
                    Some(d) => 0.5 * 10f64.powi(-d) + f32::EPSILON as f64 * want[k].abs(),
                };
                assert!(
                    (got[k] as f64 - want[k]).abs() <= tolerance,
                    "{name}: {got:?} vs {want:?}"
                );
            }
        }
    }
}
