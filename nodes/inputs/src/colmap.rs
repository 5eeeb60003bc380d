//! COLMAP sparse models (`cameras`, `images`, `points3D`, and in the newer layout
//! `rigs` and `frames`), in text and binary encodings.
//!
//! When a folder holds both encodings the binary one wins (as in COLMAP). In the
//! newer layout `images.*` still carries every registered image's camera-from-world
//! pose; the rig and frame files are read too and each image pose is checked
//! against `sensor_from_rig ∘ rig_from_world`, so a model whose files disagree is
//! refused instead of being read half right.

use crate::binio::ByteReader;
use crate::undistort::{Distortion, Intrinsics};
use anyhow::{Context, Result, bail};
use glam::{DMat3, DQuat, DVec3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// COLMAP camera models: (id, name, parameter count).
pub const CAMERA_MODELS: [(i32, &str, usize); 12] = [
    (0, "SIMPLE_PINHOLE", 3),
    (1, "PINHOLE", 4),
    (2, "SIMPLE_RADIAL", 4),
    (3, "RADIAL", 5),
    (4, "OPENCV", 8),
    (5, "OPENCV_FISHEYE", 8),
    (6, "FULL_OPENCV", 12),
    (7, "FOV", 5),
    (8, "SIMPLE_RADIAL_FISHEYE", 4),
    (9, "RADIAL_FISHEYE", 5),
    (10, "THIN_PRISM_FISHEYE", 12),
    (11, "RAD_TAN_THIN_PRISM_FISHEYE", 16),
];

#[derive(Debug, Clone, PartialEq)]
pub struct ColmapCamera {
    pub id: u32,
    pub model: &'static str,
    pub width: u32,
    pub height: u32,
    pub params: Vec<f64>,
}

impl ColmapCamera {
    /// The camera's pinhole part and its lens distortion (`None` for the pinhole
    /// models). Models without an undistortion here are refused with the step that
    /// fixes them.
    pub fn lens(&self) -> Result<(Intrinsics, Option<Distortion>), String> {
        let p = &self.params;
        let pinhole = |fx: f64, fy: f64, cx: f64, cy: f64| Intrinsics {
            width: self.width,
            height: self.height,
            fx,
            fy,
            cx,
            cy,
        };
        let brown = |k: [f64; 6], tangential: [f64; 2]| Distortion::Brown { k, p: tangential };
        Ok(match self.model {
            "SIMPLE_PINHOLE" => (pinhole(p[0], p[0], p[1], p[2]), None),
            "PINHOLE" => (pinhole(p[0], p[1], p[2], p[3]), None),
            "SIMPLE_RADIAL" => (
                pinhole(p[0], p[0], p[1], p[2]),
                Some(brown([p[3], 0.0, 0.0, 0.0, 0.0, 0.0], [0.0; 2])),
            ),
            "RADIAL" => (
                pinhole(p[0], p[0], p[1], p[2]),
                Some(brown([p[3], p[4], 0.0, 0.0, 0.0, 0.0], [0.0; 2])),
            ),
            "OPENCV" => (
                pinhole(p[0], p[1], p[2], p[3]),
                Some(brown([p[4], p[5], 0.0, 0.0, 0.0, 0.0], [p[6], p[7]])),
            ),
            "FULL_OPENCV" => (
                pinhole(p[0], p[1], p[2], p[3]),
                Some(brown([p[4], p[5], p[8], p[9], p[10], p[11]], [p[6], p[7]])),
            ),
            "OPENCV_FISHEYE" => (
                pinhole(p[0], p[1], p[2], p[3]),
                Some(Distortion::Fisheye {
                    k: [p[4], p[5], p[6], p[7]],
                }),
            ),
            "SIMPLE_RADIAL_FISHEYE" => (
                pinhole(p[0], p[0], p[1], p[2]),
                Some(Distortion::Fisheye {
                    k: [p[3], 0.0, 0.0, 0.0],
                }),
            ),
            "RADIAL_FISHEYE" => (
                pinhole(p[0], p[0], p[1], p[2]),
                Some(Distortion::Fisheye {
                    k: [p[3], p[4], 0.0, 0.0],
                }),
            ),
            other => {
                return Err(format!(
                    "camera {} uses the model {other}, which is not undistorted here (supported: SIMPLE_PINHOLE, \
                     PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV, OPENCV_FISHEYE, SIMPLE_RADIAL_FISHEYE, \
                     RADIAL_FISHEYE); undistort the images first (`colmap image_undistorter --image_path <images> \
                     --input_path <sparse> --output_path <out>` writes PINHOLE cameras and undistorted images) and \
                     point this source at the result",
                    self.id
                ));
            }
        })
    }
}

/// A rigid transform as COLMAP stores it: unit quaternion (w, x, y, z) and translation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    pub qvec: [f64; 4],
    pub tvec: [f64; 3],
}

impl Pose {
    pub const IDENTITY: Pose = Pose {
        qvec: [1.0, 0.0, 0.0, 0.0],
        tvec: [0.0; 3],
    };

    /// The rotation of the normalised quaternion.
    pub fn rotation(&self) -> DMat3 {
        let [w, x, y, z] = self.qvec;
        DMat3::from_quat(DQuat::from_xyzw(x, y, z, w).normalize())
    }

    pub fn translation(&self) -> DVec3 {
        DVec3::from_array(self.tvec)
    }

    /// The 4×4 row-major matrix (for world→camera poses: OpenCV axes, as COLMAP).
    pub fn matrix(&self) -> [[f64; 4]; 4] {
        let r = self.rotation();
        let t = self.tvec;
        let row = |i: usize| [r.col(0)[i], r.col(1)[i], r.col(2)[i], t[i]];
        [row(0), row(1), row(2), [0.0, 0.0, 0.0, 1.0]]
    }

    fn check(&self) -> Result<(), String> {
        if self.qvec.iter().chain(&self.tvec).any(|v| !v.is_finite()) {
            return Err("pose has a non-finite value".into());
        }
        let norm = self.qvec.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !norm.is_finite() || norm <= 1e-12 {
            return Err(format!(
                "pose quaternion {:?} has no usable length",
                self.qvec
            ));
        }
        Ok(())
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct ColmapImage {
    pub id: u32,
    /// Camera from world.
    pub pose: Pose,
    pub camera_id: u32,
    pub name: String,
    /// Keypoints `(x, y)` and the 3D point each observes (−1 = none).
    pub points2d: Vec<([f64; 2], i64)>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct ColmapPoint {
    pub id: u64,
    pub xyz: [f64; 3],
    pub rgb: [u8; 3],
    pub error: f64,
    /// `(image_id, point2D_idx)` observations.
    pub track: Vec<(u32, u32)>,
}

/// A sensor of a rig: (type, id). Types: "CAMERA", "IMU" (and "INVALID").
pub type SensorId = (String, u32);

#[derive(Debug, Clone, PartialEq)]
pub struct ColmapRig {
    pub id: u32,
    pub ref_sensor: Option<SensorId>,
    /// Non-reference sensors and their `sensor_from_rig` pose when known.
    pub sensors: Vec<(SensorId, Option<Pose>)>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct ColmapFrame {
    pub id: u32,
    pub rig_id: u32,
    pub rig_from_world: Pose,
    /// `(sensor, data id)`; for cameras the data id is an image id.
    pub data: Vec<(SensorId, u64)>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    Text,
    Binary,
}

#[derive(Debug, Clone, PartialEq)]
pub struct ColmapModel {
    pub dir: PathBuf,
    pub encoding: Encoding,
    pub cameras: BTreeMap<u32, ColmapCamera>,
    pub images: BTreeMap<u32, ColmapImage>,
    pub points: BTreeMap<u64, ColmapPoint>,
    /// Present in the newer layout only.
    pub rigs: Option<BTreeMap<u32, ColmapRig>>,
    pub frames: Option<BTreeMap<u32, ColmapFrame>>,
}

fn model_by_id(id: i32) -> Option<(&'static str, usize)> {
    CAMERA_MODELS.iter().find(|m| m.0 == id).map(|m| (m.1, m.2))
}

fn model_by_name(name: &str) -> Option<(&'static str, usize)> {
    CAMERA_MODELS
        .iter()
        .find(|m| m.1 == name)
        .map(|m| (m.1, m.2))
}

fn sensor_type_name(code: i32) -> Option<&'static str> {
    match code {
        -1 => Some("INVALID"),
        0 => Some("CAMERA"),
        1 => Some("IMU"),
        _ => None,
    }
}

/// Reads the model in `dir` (or in `dir/sparse/0` or `dir/sparse` when `dir` holds none).
pub fn read_model(dir: &Path) -> Result<ColmapModel> {
    let candidates = [dir.to_path_buf(), dir.join("sparse/0"), dir.join("sparse")];
    for d in &candidates {
        if d.join("cameras.bin").is_file() {
            return read_binary(d);
        }
        if d.join("cameras.txt").is_file() {
            return read_text(d);
        }
    }
    bail!(
        "{}: no COLMAP sparse model here (looked for cameras.bin or cameras.txt in it, sparse/0 and sparse)",
        dir.display()
    )
}

fn read_file(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))
}

pub fn read_binary(dir: &Path) -> Result<ColmapModel> {
    let path = dir.join("cameras.bin");
    let bytes = read_file(&path)?;
    let cameras = parse_cameras_bin(&bytes, &path)?;
    let path = dir.join("images.bin");
    let images = parse_images_bin(&read_file(&path)?, &path)?;
    let path = dir.join("points3D.bin");
    let points = parse_points_bin(&read_file(&path)?, &path)?;
    let rigs_and_frames = if has_rigs_and_frames(dir, "bin")? {
        let (r, f) = (dir.join("rigs.bin"), dir.join("frames.bin"));
        Some((
            parse_rigs_bin(&read_file(&r)?, &r)?,
            parse_frames_bin(&read_file(&f)?, &f)?,
        ))
    } else {
        None
    };
    ColmapModel::checked(
        dir,
        Encoding::Binary,
        cameras,
        images,
        points,
        rigs_and_frames,
    )
}

pub fn read_text(dir: &Path) -> Result<ColmapModel> {
    let text = |name: &str| -> Result<(PathBuf, String)> {
        let path = dir.join(name);
        let s = std::fs::read_to_string(&path)
            .with_context(|| format!("{}: cannot read as text", path.display()))?;
        Ok((path, s))
    };
    let (p, s) = text("cameras.txt")?;
    let cameras = parse_cameras_txt(&s, &p)?;
    let (p, s) = text("images.txt")?;
    let images = parse_images_txt(&s, &p)?;
    let (p, s) = text("points3D.txt")?;
    let points = parse_points_txt(&s, &p)?;
    let rigs_and_frames = if has_rigs_and_frames(dir, "txt")? {
        let (rp, rs) = text("rigs.txt")?;
        let (fp, fs) = text("frames.txt")?;
        Some((parse_rigs_txt(&rs, &rp)?, parse_frames_txt(&fs, &fp)?))
    } else {
        None
    };
    ColmapModel::checked(
        dir,
        Encoding::Text,
        cameras,
        images,
        points,
        rigs_and_frames,
    )
}

/// Whether `dir` holds the newer layout's rig and frame files (with the extension `ext`);
/// only one of them is an error.
fn has_rigs_and_frames(dir: &Path, ext: &str) -> Result<bool> {
    match (
        dir.join(format!("rigs.{ext}")).is_file(),
        dir.join(format!("frames.{ext}")).is_file(),
    ) {
        (true, true) => Ok(true),
        (false, false) => Ok(false),
        _ => bail!(
            "{}: has only one of rigs.{ext} and frames.{ext}; the newer layout needs both",
            dir.display()
        ),
    }
}

impl ColmapModel {
    /// The model of the parsed files, refused unless they agree with each other.
    fn checked(
        dir: &Path,
        encoding: Encoding,
        cameras: BTreeMap<u32, ColmapCamera>,
        images: BTreeMap<u32, ColmapImage>,
        points: BTreeMap<u64, ColmapPoint>,
        rigs_and_frames: Option<(BTreeMap<u32, ColmapRig>, BTreeMap<u32, ColmapFrame>)>,
    ) -> Result<ColmapModel> {
        let (rigs, frames) = rigs_and_frames.unzip();
        let model = ColmapModel {
            dir: dir.to_path_buf(),
            encoding,
            cameras,
            images,
            points,
            rigs,
            frames,
        };
        model.check()?;
        Ok(model)
    }

    /// Cross-file consistency: referenced cameras exist, rig/frame poses agree with image poses.
    fn check(&self) -> Result<()> {
        for img in self.images.values() {
            if !self.cameras.contains_key(&img.camera_id) {
                bail!(
                    "{}: image {} ({:?}) refers to camera {}, which the cameras file does not define",
                    self.dir.display(),
                    img.id,
                    img.name,
                    img.camera_id
                );
            }
        }
        let (Some(rigs), Some(frames)) = (&self.rigs, &self.frames) else {
            return Ok(());
        };
        for frame in frames.values() {
            let rig = rigs.get(&frame.rig_id).with_context(|| {
                format!(
                    "{}: frame {} refers to rig {}, which is not defined",
                    self.dir.display(),
                    frame.id,
                    frame.rig_id
                )
            })?;
            for ((kind, sensor), data_id) in &frame.data {
                if kind != "CAMERA" {
                    continue;
                }
                let Some(img) = u32::try_from(*data_id)
                    .ok()
                    .and_then(|id| self.images.get(&id))
                else {
                    // Frames may list images that were not registered; images.* holds only registered ones.
                    continue;
                };
                let sensor_from_rig = if rig.ref_sensor.as_ref() == Some(&(kind.clone(), *sensor)) {
                    Some(Pose::IDENTITY)
                } else {
                    rig.sensors
                        .iter()
                        .find(|(s, _)| s.0 == *kind && s.1 == *sensor)
                        .and_then(|(_, p)| *p)
                };
                let Some(sensor_from_rig) = sensor_from_rig else {
                    continue;
                };
                let r = sensor_from_rig.rotation() * frame.rig_from_world.rotation();
                let t = sensor_from_rig.rotation() * frame.rig_from_world.translation()
                    + sensor_from_rig.translation();
                let dr = (r - img.pose.rotation())
                    .to_cols_array()
                    .iter()
                    .fold(0.0f64, |m, v| m.max(v.abs()));
                let dt = (t - img.pose.translation()).abs().max_element();
                if dr > 1e-9 || dt > 1e-9 * t.length().max(1.0) {
                    bail!(
                        "{}: image {} ({:?}) pose disagrees with rig {} ∘ frame {} (rotation off by {dr:.2e}, translation by {dt:.2e})",
                        self.dir.display(),
                        img.id,
                        img.name,
                        rig.id,
                        frame.id
                    );
                }
            }
        }
        Ok(())
    }
}

/// An error in the record of a binary file that starts at byte `at`.
fn byte_error(path: &Path, at: usize, message: impl std::fmt::Display) -> anyhow::Error {
    anyhow::anyhow!("{}: byte {at}: {message}", path.display())
}

/// Adds a record under its id: ids are unique within a model file, so a repeat is an
/// error (the message says which record, for the caller to locate).
fn insert_new<K: Ord + Copy + std::fmt::Display, V>(
    records: &mut BTreeMap<K, V>,
    id: K,
    record: V,
    kind: &str,
) -> Result<(), String> {
    match records.insert(id, record) {
        Some(_) => Err(format!("{kind} {id} appears twice")),
        None => Ok(()),
    }
}

/// A binary model file: a record count, then the records (each at least
/// `min_record_bytes` long), keyed by id. `record` reads one, given the byte it starts at.
fn parse_records_bin<K: Ord + Copy + std::fmt::Display, V>(
    bytes: &[u8],
    path: &Path,
    count_what: &str,
    min_record_bytes: usize,
    kind: &str,
    mut record: impl FnMut(&mut ByteReader, usize) -> Result<(K, V)>,
) -> Result<BTreeMap<K, V>> {
    let mut r = ByteReader::new(bytes, path);
    let n = r.count(count_what, min_record_bytes)?;
    let mut out = BTreeMap::new();
    for _ in 0..n {
        let at = r.position();
        let (id, value) = record(&mut r, at)?;
        insert_new(&mut out, id, value, kind).map_err(|e| byte_error(path, at, e))?;
    }
    r.finish()?;
    Ok(out)
}

/// A text model file of one record a data line, keyed by id.
fn parse_records_txt<K: Ord + Copy + std::fmt::Display, V>(
    text: &str,
    path: &Path,
    kind: &str,
    mut record: impl FnMut(&mut Fields) -> Result<(K, V)>,
) -> Result<BTreeMap<K, V>> {
    let mut out = BTreeMap::new();
    for (line, l) in data_lines(text) {
        let mut f = Fields::new(l, path, line);
        let (id, value) = record(&mut f)?;
        insert_new(&mut out, id, value, kind).map_err(|e| f.err(e))?;
    }
    Ok(out)
}

fn parse_cameras_bin(bytes: &[u8], path: &Path) -> Result<BTreeMap<u32, ColmapCamera>> {
    parse_records_bin(bytes, path, "number of cameras", 24, "camera", |r, at| {
        let id = r.u32("camera_id")?;
        let model_id = r.i32("model_id")?;
        let (model, k) = model_by_id(model_id).with_context(|| {
            format!(
                "{}: byte {at}: camera {id} has unknown model id {model_id}",
                path.display()
            )
        })?;
        let width = r.u64("width")?;
        let height = r.u64("height")?;
        let params = (0..k)
            .map(|_| r.f64("camera params"))
            .collect::<Result<Vec<_>>>()?;
        let cam = camera(id, model, width, height, params).map_err(|e| byte_error(path, at, e))?;
        Ok((id, cam))
    })
}

fn camera(
    id: u32,
    model: &'static str,
    width: u64,
    height: u64,
    params: Vec<f64>,
) -> Result<ColmapCamera, String> {
    let dim = |v: u64, what: &str| -> Result<u32, String> {
        u32::try_from(v)
            .ok()
            .filter(|&v| v > 0)
            .ok_or_else(|| format!("camera {id} {what} {v} is not a usable size"))
    };
    if params.iter().any(|p| !p.is_finite()) {
        return Err(format!("camera {id} has a non-finite parameter {params:?}"));
    }
    Ok(ColmapCamera {
        id,
        model,
        width: dim(width, "width")?,
        height: dim(height, "height")?,
        params,
    })
}

/// A pose as binary records store it (`what` names its fields in read errors), checked;
/// `owner` names the record in the error when it is unusable.
fn pose_bin(
    r: &mut ByteReader,
    path: &Path,
    at: usize,
    what: &str,
    owner: impl std::fmt::Display,
) -> Result<Pose> {
    let pose = Pose {
        qvec: r.f64s(&format!("{what} qvec"))?,
        tvec: r.f64s(&format!("{what} tvec"))?,
    };
    pose.check()
        .map_err(|e| byte_error(path, at, format!("{owner}: {e}")))?;
    Ok(pose)
}

fn parse_images_bin(bytes: &[u8], path: &Path) -> Result<BTreeMap<u32, ColmapImage>> {
    parse_records_bin(
        bytes,
        path,
        "number of images",
        4 + 56 + 4 + 1 + 8,
        "image",
        |r, at| {
            let id = r.u32("image_id")?;
            let image = ColmapImage {
                id,
                pose: pose_bin(r, path, at, "image", format_args!("image {id}"))?,
                camera_id: r.u32("camera_id")?,
                name: r.c_string("image name")?,
                points2d: r.list("number of 2D points", 24, |r| {
                    Ok((r.f64s::<2>("2D point")?, r.i64("point3D_id")?))
                })?,
            };
            Ok((id, image))
        },
    )
}

fn parse_points_bin(bytes: &[u8], path: &Path) -> Result<BTreeMap<u64, ColmapPoint>> {
    parse_records_bin(
        bytes,
        path,
        "number of 3D points",
        8 + 24 + 3 + 8 + 8,
        "point",
        |r, at| {
            let id = r.u64("point3D_id")?;
            let xyz = r.f64s::<3>("point xyz")?;
            let rgb = [r.u8("red")?, r.u8("green")?, r.u8("blue")?];
            let error = r.f64("point error")?;
            if xyz.iter().any(|v| !v.is_finite()) {
                return Err(byte_error(
                    path,
                    at,
                    format!("point {id} has a non-finite coordinate {xyz:?}"),
                ));
            }
            let point = ColmapPoint {
                id,
                xyz,
                rgb,
                error,
                track: r.list("track length", 8, |r| {
                    Ok((r.u32("track image_id")?, r.u32("track point2D_idx")?))
                })?,
            };
            Ok((id, point))
        },
    )
}

fn sensor_bin(r: &mut ByteReader, path: &Path) -> Result<SensorId> {
    let at = r.position();
    let code = r.i32("sensor type")?;
    let kind = sensor_type_name(code)
        .with_context(|| format!("{}: byte {at}: unknown sensor type {code}", path.display()))?;
    Ok((kind.to_string(), r.u32("sensor id")?))
}

fn parse_rigs_bin(bytes: &[u8], path: &Path) -> Result<BTreeMap<u32, ColmapRig>> {
    parse_records_bin(bytes, path, "number of rigs", 8, "rig", |r, at| {
        let id = r.u32("rig_id")?;
        let num_sensors = r.u32("number of sensors")? as usize;
        let mut rig = ColmapRig {
            id,
            ref_sensor: None,
            sensors: Vec::new(),
        };
        if num_sensors > 0 {
            rig.ref_sensor = Some(sensor_bin(r, path)?);
            for _ in 1..num_sensors {
                let sensor = sensor_bin(r, path)?;
                let pose = match r.u8("has_pose")? {
                    0 => None,
                    _ => Some(pose_bin(r, path, at, "sensor", format_args!("rig {id}"))?),
                };
                rig.sensors.push((sensor, pose));
            }
        }
        Ok((id, rig))
    })
}

fn parse_frames_bin(bytes: &[u8], path: &Path) -> Result<BTreeMap<u32, ColmapFrame>> {
    parse_records_bin(
        bytes,
        path,
        "number of frames",
        4 + 4 + 56 + 4,
        "frame",
        |r, at| {
            let id = r.u32("frame_id")?;
            let rig_id = r.u32("rig_id")?;
            let rig_from_world = pose_bin(r, path, at, "frame", format_args!("frame {id}"))?;
            let count = r.u32("number of data ids")? as usize;
            if count.saturating_mul(16) > r.remaining() {
                return Err(byte_error(
                    path,
                    at,
                    format!("frame {id} lists {count} data ids, more than the file holds"),
                ));
            }
            let mut data = Vec::with_capacity(count);
            for _ in 0..count {
                let sensor = sensor_bin(r, path)?;
                data.push((sensor, r.u64("data id")?));
            }
            let frame = ColmapFrame {
                id,
                rig_id,
                rig_from_world,
                data,
            };
            Ok((id, frame))
        },
    )
}

/// Whitespace tokens of one text line, with errors that name the file and line.
struct Fields<'a> {
    words: std::str::SplitWhitespace<'a>,
    path: &'a Path,
    line: usize,
}

impl<'a> Fields<'a> {
    fn new(text: &'a str, path: &'a Path, line: usize) -> Fields<'a> {
        Fields {
            words: text.split_whitespace(),
            path,
            line,
        }
    }

    fn word(&mut self, what: &str) -> Result<&'a str> {
        self.words.next().with_context(|| {
            format!(
                "{}:{}: line ends before {what}",
                self.path.display(),
                self.line
            )
        })
    }

    fn parse<T: std::str::FromStr>(&mut self, what: &str) -> Result<T> {
        let w = self.word(what)?;
        w.parse().map_err(|_| {
            anyhow::anyhow!(
                "{}:{}: {what} {w:?} is not valid",
                self.path.display(),
                self.line
            )
        })
    }

    fn f64s<const N: usize>(&mut self, what: &str) -> Result<[f64; N]> {
        let mut out = [0.0; N];
        for v in &mut out {
            *v = self.parse(what)?;
        }
        Ok(out)
    }

    /// A pose as text records store it (`prefix` starts its field names in read errors),
    /// checked; `owner` names the record in the error when it is unusable.
    fn pose(&mut self, prefix: &str, owner: impl std::fmt::Display) -> Result<Pose> {
        let pose = Pose {
            qvec: self.f64s(&format!("{prefix}QW QX QY QZ"))?,
            tvec: self.f64s(&format!("{prefix}TX TY TZ"))?,
        };
        pose.check()
            .map_err(|e| self.err(format!("{owner}: {e}")))?;
        Ok(pose)
    }

    fn sensor(&mut self) -> Result<SensorId> {
        let kind = self.word("sensor type")?;
        if !matches!(kind, "CAMERA" | "IMU" | "INVALID") {
            bail!(
                "{}:{}: unknown sensor type {kind:?}",
                self.path.display(),
                self.line
            );
        }
        Ok((kind.to_string(), self.parse("sensor id")?))
    }

    /// Items read by `item` until the line ends.
    fn until_line_end<T>(
        &mut self,
        mut item: impl FnMut(&mut Self) -> Result<T>,
    ) -> Result<Vec<T>> {
        let mut items = Vec::new();
        while !self.is_done() {
            items.push(item(self)?);
        }
        Ok(items)
    }

    fn is_done(&mut self) -> bool {
        self.words.clone().next().is_none()
    }

    fn err(&self, message: impl std::fmt::Display) -> anyhow::Error {
        anyhow::anyhow!("{}:{}: {message}", self.path.display(), self.line)
    }
}

/// What follows the first `n` whitespace-separated tokens of `line`, trimmed.
fn rest_after_tokens(line: &str, n: usize) -> Option<&str> {
    let mut rest = line;
    for _ in 0..n {
        rest = rest.trim_start();
        rest = &rest[rest.find(char::is_whitespace)?..];
    }
    let rest = rest.trim();
    (!rest.is_empty()).then_some(rest)
}

/// Data lines (1-based line number, text), skipping comments and blank lines.
fn data_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
}

fn parse_cameras_txt(text: &str, path: &Path) -> Result<BTreeMap<u32, ColmapCamera>> {
    parse_records_txt(text, path, "camera", |f| {
        let id: u32 = f.parse("CAMERA_ID")?;
        let name = f.word("MODEL")?;
        let (model, k) =
            model_by_name(name).ok_or_else(|| f.err(format!("unknown camera model {name:?}")))?;
        let width: u64 = f.parse("WIDTH")?;
        let height: u64 = f.parse("HEIGHT")?;
        let params = (0..k)
            .map(|_| f.parse::<f64>("camera parameter"))
            .collect::<Result<Vec<_>>>()?;
        if !f.is_done() {
            return Err(f.err(format!("{model} takes {k} parameters; the line has more")));
        }
        let cam = camera(id, model, width, height, params).map_err(|e| f.err(e))?;
        Ok((id, cam))
    })
}

fn parse_images_txt(text: &str, path: &Path) -> Result<BTreeMap<u32, ColmapImage>> {
    let mut out = BTreeMap::new();
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l.trim()));
    while let Some((line, l)) = lines.next() {
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let mut f = Fields::new(l, path, line);
        let id: u32 = f.parse("IMAGE_ID")?;
        let pose = f.pose("", format_args!("image {id}"))?;
        let camera_id: u32 = f.parse("CAMERA_ID")?;
        // Names may contain spaces: the name is the rest of the line.
        let name = rest_after_tokens(l, 9)
            .ok_or_else(|| f.err("line ends before NAME"))?
            .to_string();
        // The second line of an image (its keypoints) may be empty, but it is always there.
        let (kp_line, kp) = lines.next().unwrap_or((line + 1, ""));
        let points2d = Fields::new(kp, path, kp_line).until_line_end(|k| {
            let xy = k.f64s::<2>("POINTS2D x y")?;
            Ok((xy, k.parse::<i64>("POINT3D_ID")?))
        })?;
        let image = ColmapImage {
            id,
            pose,
            camera_id,
            name,
            points2d,
        };
        insert_new(&mut out, id, image, "image").map_err(|e| f.err(e))?;
    }
    Ok(out)
}

fn parse_points_txt(text: &str, path: &Path) -> Result<BTreeMap<u64, ColmapPoint>> {
    parse_records_txt(text, path, "point", |f| {
        let id: u64 = f.parse("POINT3D_ID")?;
        let xyz = f.f64s::<3>("X Y Z")?;
        if xyz.iter().any(|v| !v.is_finite()) {
            return Err(f.err(format!("point {id} has a non-finite coordinate")));
        }
        let point = ColmapPoint {
            id,
            xyz,
            rgb: [f.parse("R")?, f.parse("G")?, f.parse("B")?],
            error: f.parse("ERROR")?,
            track: f.until_line_end(|f| {
                Ok((f.parse("track IMAGE_ID")?, f.parse("track POINT2D_IDX")?))
            })?,
        };
        Ok((id, point))
    })
}

fn parse_rigs_txt(text: &str, path: &Path) -> Result<BTreeMap<u32, ColmapRig>> {
    parse_records_txt(text, path, "rig", |f| {
        let id: u32 = f.parse("RIG_ID")?;
        let num_sensors: usize = f.parse("NUM_SENSORS")?;
        let mut rig = ColmapRig {
            id,
            ref_sensor: None,
            sensors: Vec::new(),
        };
        if num_sensors > 0 {
            rig.ref_sensor = Some(f.sensor()?);
            for _ in 1..num_sensors {
                let sensor = f.sensor()?;
                let pose = match f.parse::<u8>("HAS_POSE")? {
                    0 => None,
                    _ => Some(f.pose("sensor ", format_args!("rig {id}"))?),
                };
                rig.sensors.push((sensor, pose));
            }
        }
        Ok((id, rig))
    })
}

fn parse_frames_txt(text: &str, path: &Path) -> Result<BTreeMap<u32, ColmapFrame>> {
    parse_records_txt(text, path, "frame", |f| {
        let id: u32 = f.parse("FRAME_ID")?;
        let rig_id: u32 = f.parse("RIG_ID")?;
        let rig_from_world = f.pose("", format_args!("frame {id}"))?;
        let count: usize = f.parse("NUM_DATA_IDS")?;
        let frame = ColmapFrame {
            id,
            rig_id,
            rig_from_world,
            data: (0..count)
                .map(|_| Ok((f.sensor()?, f.parse("DATA_ID")?)))
                .collect::<Result<_>>()?,
        };
        Ok((id, frame))
    })
}

/// Parses in-memory binary model files (for fuzzing and tests): cameras, images, points3D.
pub fn parse_binary_files(cameras: &[u8], images: &[u8], points: &[u8]) -> Result<()> {
    parse_cameras_bin(cameras, Path::new("cameras.bin"))?;
    parse_images_bin(images, Path::new("images.bin"))?;
    parse_points_bin(points, Path::new("points3D.bin"))?;
    Ok(())
}

/// Parses in-memory rig and frame files (for fuzzing).
pub fn parse_rig_files(rigs: &[u8], frames: &[u8]) -> Result<()> {
    parse_rigs_bin(rigs, Path::new("rigs.bin"))?;
    parse_frames_bin(frames, Path::new("frames.bin"))?;
    Ok(())
}
