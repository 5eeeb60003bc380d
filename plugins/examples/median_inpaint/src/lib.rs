//! Example plugin: fills the masked pixels of an image by iterated median of their
//! known neighbours, working inwards from the mask's border. Pixels outside the mask
//! are copied bit for bit (same bit depth as the input), so it can stand in for the
//! built-in `inpaint` node wherever a hole-filling image stage is wanted.

use objectsplat_plugin_sdk::prelude::*;

/// Neighbour offsets for 4- and 8-connectivity.
const N4: &[(i64, i64)] = &[(-1, 0), (1, 0), (0, -1), (0, 1)];
const N8: &[(i64, i64)] = &[
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

/// Fills every unknown pixel in passes: each pass gives every unknown pixel that has
/// a known neighbour the per-channel lower median of those neighbours, then marks
/// them known. Returns the number of passes.
pub fn median_fill(image: &mut Image, known: &mut [bool], offsets: &[(i64, i64)]) -> Result<usize> {
    let (w, h, ch) = (
        image.width as i64,
        image.height as i64,
        image.channels as usize,
    );
    if !known.iter().any(|&k| k) {
        bail!("the mask covers the whole image: there is no known pixel to fill from");
    }
    let mut passes = 0;
    let mut values = Vec::with_capacity(offsets.len());
    while known.iter().any(|&k| !k) {
        let mut filled: Vec<(usize, Vec<f32>)> = vec![];
        for y in 0..h {
            for x in 0..w {
                let p = (y * w + x) as usize;
                if known[p] {
                    continue;
                }
                let neighbours: Vec<usize> = offsets
                    .iter()
                    .map(|&(dx, dy)| (x + dx, y + dy))
                    .filter(|&(nx, ny)| nx >= 0 && ny >= 0 && nx < w && ny < h)
                    .map(|(nx, ny)| (ny * w + nx) as usize)
                    .filter(|&q| known[q])
                    .collect();
                if neighbours.is_empty() {
                    continue;
                }
                let px = (0..ch)
                    .map(|c| {
                        values.clear();
                        values.extend(neighbours.iter().map(|&q| image.data[q * ch + c]));
                        values.sort_by(f32::total_cmp);
                        values[(values.len() - 1) / 2]
                    })
                    .collect();
                filled.push((p, px));
            }
        }
        // Every pass fills at least the unknown pixels next to known ones; the grid is
        // connected and one pixel is known, so this only happens on a logic error.
        if filled.is_empty() {
            bail!("no unknown pixel touches a known one (internal error)");
        }
        for (p, px) in filled {
            image.data[p * ch..(p + 1) * ch].copy_from_slice(&px);
            known[p] = true;
        }
        passes += 1;
    }
    Ok(passes)
}

fn median_inpaint(req: &mut Request) -> Result<Outcome> {
    let image_dir = req.input("image")?;
    let mut image = read_image(image_dir)?;
    let depth = image_bit_depth(image_dir)?;
    let mask = read_mask(req.input("mask")?)?;
    if (mask.width, mask.height) != (image.width, image.height) {
        bail!(
            "mask is {}×{} but the image is {}×{}",
            mask.width,
            mask.height,
            image.width,
            image.height
        );
    }
    let holes = mask.set.iter().filter(|&&s| s).count();
    if holes == 0 {
        req.forward("image", "image")?;
        return Ok(Outcome::Skipped(
            "the mask is empty: nothing to fill".into(),
        ));
    }
    let offsets = match req.param::<String>("connectivity")?.as_str() {
        "4" => N4,
        _ => N8,
    };
    let mut known: Vec<bool> = mask.set.iter().map(|&s| !s).collect();
    let passes = median_fill(&mut image, &mut known, offsets)?;
    write_image(&req.output("image")?, &image, depth)?;
    req.note("filled_pixels", holes);
    req.note("passes", passes);
    Ok(Outcome::Done)
}

/// The code version: bump when the output for the same inputs changes. The
/// environment override exists for the host's cache tests (tests/plugins.rs).
const VERSION: &str = match option_env!("OBJECTSPLAT_EXAMPLE_CODE_VERSION") {
    Some(v) => v,
    None => "1",
};

export_plugin!(
    Plugin::new("median_inpaint", VERSION).node(
        NodeDecl::new("median_inpaint", median_inpaint)
            .doc("Fills masked pixels by iterated median of known neighbours; pixels outside the mask are unchanged.")
            .input("image", "Image", "the image with holes")
            .input("mask", "Mask", "set = pixel to fill")
            .output("image", "Image", "the filled image, same bit depth")
            .param("connectivity", "enum(4|8)", Some("\"8\""), "which neighbours count"),
    )
);
