//! The Masks artifact: per-frame object-id maps.
//!
//! Encoding (a folder): one 16-bit grey PNG per frame named `<frame stem>.png`,
//! pixel = object id, `0` = no object, [`UNOWNED`] = no surface at all (a hole in
//! the source scan; partition gives it to the background); plus `objects.json`,
//! a JSON object mapping object id (as a string) to its label.

use crate::artifact::OBJECTS_JSON;
use anyhow::{Context, Result, bail};
use std::collections::BTreeMap;
use std::path::Path;

/// Marks pixels that no surface owns. Never an object id.
pub const UNOWNED: u16 = u16::MAX;
pub const NO_OBJECT: u16 = 0;

/// A per-pixel object-id map.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IdMap {
    pub width: u32,
    pub height: u32,
    pub data: Vec<u16>,
}

impl IdMap {
    pub fn new(width: u32, height: u32) -> IdMap {
        IdMap {
            width,
            height,
            data: vec![NO_OBJECT; (width * height) as usize],
        }
    }

    #[inline]
    pub fn get(&self, x: u32, y: u32) -> u16 {
        self.data[(y * self.width + x) as usize]
    }

    pub fn load(path: &Path) -> Result<IdMap> {
        let img = image::ImageReader::open(path)
            .with_context(|| format!("{}: cannot open mask", path.display()))?
            .with_guessed_format()?
            .decode()
            .with_context(|| format!("{}: not a decodable PNG", path.display()))?;
        let (width, height) = (img.width(), img.height());
        let data = match img {
            image::DynamicImage::ImageLuma16(b) => b.into_raw(),
            image::DynamicImage::ImageLuma8(b) => b.into_raw().into_iter().map(u16::from).collect(),
            other => bail!(
                "{}: expected a 16-bit grey id map, found {:?}",
                path.display(),
                other.color()
            ),
        };
        Ok(IdMap {
            width,
            height,
            data,
        })
    }

    pub fn save(&self, path: &Path) -> Result<()> {
        let raw: Vec<u8> = self.data.iter().flat_map(|v| v.to_ne_bytes()).collect();
        image::save_buffer_with_format(
            path,
            &raw,
            self.width,
            self.height,
            image::ExtendedColorType::L16,
            image::ImageFormat::Png,
        )
        .with_context(|| format!("{}: cannot write mask", path.display()))
    }
}

/// Object id → label, as stored in `objects.json`.
pub type ObjectLabels = BTreeMap<u16, String>;

pub fn read_objects(dir: &Path) -> Result<ObjectLabels> {
    let path = dir.join(OBJECTS_JSON);
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let raw: BTreeMap<String, String> = serde_json::from_str(&text)
        .with_context(|| format!("{}: expected {{\"id\": \"label\"}}", path.display()))?;
    let mut out = ObjectLabels::new();
    for (k, v) in raw {
        let id: u16 = k
            .parse()
            .ok()
            .filter(|&id| id != NO_OBJECT && id != UNOWNED)
            .with_context(|| {
                format!(
                    "{}: object id {k:?} is not an integer in 1..=65534",
                    path.display()
                )
            })?;
        out.insert(id, v);
    }
    Ok(out)
}

pub fn write_objects(dir: &Path, labels: &ObjectLabels) -> Result<()> {
    let raw: BTreeMap<String, &String> = labels.iter().map(|(k, v)| (k.to_string(), v)).collect();
    // Keys sorted numerically would be nicer to read, but BTreeMap<String> keeps the
    // bytes deterministic, which is what the cache needs.
    std::fs::write(dir.join(OBJECTS_JSON), serde_json::to_string_pretty(&raw)?)
        .with_context(|| format!("{}: cannot write", dir.join(OBJECTS_JSON).display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn idmap_and_labels_roundtrip() {
        let dir = tempfile::tempdir().unwrap();
        let mut m = IdMap::new(5, 3);
        m.data[4] = 7;
        m.data[9] = UNOWNED;
        m.save(&dir.path().join("f.png")).unwrap();
        assert_eq!(IdMap::load(&dir.path().join("f.png")).unwrap(), m);
        let labels: ObjectLabels = [(7, "chair".to_string()), (12, "table".to_string())].into();
        write_objects(dir.path(), &labels).unwrap();
        assert_eq!(read_objects(dir.path()).unwrap(), labels);
    }
}
