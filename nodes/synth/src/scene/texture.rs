//! Procedural materials evaluated at world positions, and the fixed lighting baked into colours.
//!
//! Everything is a pure function of the position, the face normal and the scene's
//! texture seed, so the same surface point has the same colour in every view.

use glam::DVec3;

/// What a face is made of; colours are sRGB-encoded values in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Material {
    /// Planks along x with grain, per-plank tint and dark joints.
    WoodFloor,
    /// Off-white wallpaper with pale vertical stripes and mottling.
    Wallpaper,
    /// Plain ceiling paint with faint noise.
    Ceiling,
    /// Concentric growth rings distorted by noise.
    Wood { base: [f64; 3] },
    /// A checkerboard of `size`-metre squares.
    Checker { a: [f64; 3], b: [f64; 3], size: f64 },
    /// Horizontal bands along z, `period` metres.
    Stripes {
        a: [f64; 3],
        b: [f64; 3],
        period: f64,
    },
    /// Beach-ball segments around the vertical axis through `center`.
    Segments {
        center: [f64; 3],
        colors: [[f64; 3]; 3],
    },
    /// Woven fabric: a fine cross-hatch over mottled colour.
    Fabric { base: [f64; 3] },
    /// Brushed metal: fine streaks along z.
    Metal { base: [f64; 3] },
    /// A brick wainscot (the lower metre, running bond, mortar joints) under
    /// wallpaper, with a printed notice of text-like glyphs at eye height.
    BrickWall,
    /// Square tiles with grout lines, and a patterned rug on them.
    TiledFloor,
}

/// The rug of [`Material::TiledFloor`]: x and y ranges (metres), beside the table.
pub const RUG: ([f64; 2], [f64; 2]) = ([-1.7, -0.5], [-1.4, 0.6]);

/// Brick size with its joint (metres) and the wainscot's height.
const BRICK: (f64, f64, f64) = (0.21, 0.075, 1.0);

/// The notice on each wall: its extent along the wall and in height (metres),
/// and one glyph cell (width, height) of 3×5 strokes.
const NOTICE: ([f64; 2], [f64; 2], (f64, f64)) = ([-0.9, -0.2], [1.35, 1.75], (0.027, 0.045));

/// Deterministic lattice hash to [0, 1).
fn hash3(x: i64, y: i64, z: i64, seed: u64) -> f64 {
    let mut h = seed ^ 0x9E37_79B9_7F4A_7C15;
    for v in [x, y, z] {
        h ^= (v as u64).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h = h.rotate_left(27).wrapping_mul(0x94D0_49BB_1331_11EB);
    }
    h ^= h >> 31;
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// Smooth value noise in [0, 1).
fn value_noise(p: DVec3, seed: u64) -> f64 {
    let i = p.floor();
    let f = p - i;
    let s = f * f * (DVec3::splat(3.0) - 2.0 * f);
    let (ix, iy, iz) = (i.x as i64, i.y as i64, i.z as i64);
    let mut acc = 0.0;
    for dz in 0..2 {
        for dy in 0..2 {
            for dx in 0..2 {
                let w = (if dx == 1 { s.x } else { 1.0 - s.x })
                    * (if dy == 1 { s.y } else { 1.0 - s.y })
                    * (if dz == 1 { s.z } else { 1.0 - s.z });
                acc += w * hash3(ix + dx, iy + dy, iz + dz, seed);
            }
        }
    }
    acc
}

/// Fractal sum of four octaves of value noise, in [0, 1).
pub fn fbm(p: DVec3, seed: u64) -> f64 {
    let (mut sum, mut amp, mut norm, mut q) = (0.0, 0.5, 0.0, p);
    for octave in 0..4 {
        sum += amp * value_noise(q, seed.wrapping_add(octave));
        norm += amp;
        amp *= 0.5;
        q *= 2.03;
    }
    sum / norm
}

fn mix(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}

fn scale(c: [f64; 3], k: f64) -> [f64; 3] {
    [c[0] * k, c[1] * k, c[2] * k]
}

/// Surface colour before lighting.
pub fn albedo(material: &Material, p: DVec3, seed: u64) -> [f64; 3] {
    match *material {
        Material::WoodFloor => {
            let plank_width = 0.18;
            let plank = (p.y / plank_width).floor();
            let across = p.y / plank_width - plank;
            // Planks are staggered along their length so joints do not line up.
            let along = p.x + hash3(plank as i64, 0, 0, seed) * 1.3;
            let board = (along / 1.3).floor();
            let tint = hash3(plank as i64, board as i64, 1, seed);
            let grain =
                (p.y * 90.0 + 7.0 * fbm(DVec3::new(along * 0.8, p.y * 12.0, board), seed)).sin();
            let base = mix([0.55, 0.38, 0.22], [0.68, 0.5, 0.3], tint);
            let mut c = scale(base, 0.9 + 0.1 * grain);
            let joint = !(0.03..=0.97).contains(&across) || (along / 1.3 - board) < 0.006;
            if joint {
                c = scale(c, 0.45);
            }
            c
        }
        Material::Wallpaper => {
            let stripe = ((p.x + p.y) / 0.15).floor() as i64 % 2 == 0;
            let base = if stripe {
                [0.86, 0.84, 0.78]
            } else {
                [0.8, 0.82, 0.8]
            };
            let mottling = fbm(p * 6.0, seed.wrapping_add(11));
            scale(base, 0.88 + 0.16 * mottling)
        }
        Material::Ceiling => scale(
            [0.92, 0.92, 0.9],
            0.94 + 0.06 * fbm(p * 4.0, seed.wrapping_add(13)),
        ),
        Material::Wood { base } => {
            let q = DVec3::new(p.x * 0.6, p.y * 3.0, p.z * 3.0);
            let rings = ((p.y * p.y + p.z * p.z).sqrt() * 40.0
                + 6.0 * fbm(q, seed.wrapping_add(17)))
            .fract();
            let dark = scale(base, 0.7);
            mix(base, dark, smooth_pulse(rings))
        }
        Material::Checker { a, b, size } => {
            let cell = (p / size).floor();
            let parity = (cell.x + cell.y + cell.z).rem_euclid(2.0) < 0.5;
            let base = if parity { a } else { b };
            scale(base, 0.9 + 0.1 * fbm(p * 20.0, seed.wrapping_add(19)))
        }
        Material::Stripes { a, b, period } => {
            let t = (p.z / period).fract();
            let wobble = 0.05 * (fbm(p * 15.0, seed.wrapping_add(23)) - 0.5);
            if (t + wobble).rem_euclid(1.0) < 0.5 {
                a
            } else {
                b
            }
        }
        Material::Segments { center, colors } => {
            let d = p - DVec3::from(center);
            let angle = d.y.atan2(d.x) + std::f64::consts::PI;
            let segment = ((angle / (std::f64::consts::TAU / 6.0)).floor() as usize) % 3;
            // A white cap at the poles, like a beach ball.
            if d.z.abs() > 0.85 * d.length() {
                [0.95, 0.95, 0.93]
            } else {
                colors[segment]
            }
        }
        Material::Fabric { base } => {
            let weave =
                0.5 + 0.25 * ((p.x + p.z) * 900.0).sin() + 0.25 * ((p.y - p.z) * 900.0).sin();
            let mottle = fbm(p * 8.0, seed.wrapping_add(29));
            scale(base, 0.75 + 0.15 * weave + 0.2 * mottle)
        }
        Material::BrickWall => brick_wall(p, seed),
        Material::TiledFloor => tiled_floor(p, seed),
        Material::Metal { base } => {
            let streak = fbm(
                DVec3::new(p.x * 60.0, p.y * 60.0, p.z * 2.0),
                seed.wrapping_add(31),
            );
            scale(base, 0.8 + 0.3 * streak)
        }
    }
}

/// A wall point's coordinate along its wall: every wall of the room lies at
/// x = ±2 or y = ±2, so the other coordinate runs along it.
fn along_wall(p: DVec3) -> f64 {
    if p.x.abs() > p.y.abs() { p.y } else { p.x }
}

fn brick_wall(p: DVec3, seed: u64) -> [f64; 3] {
    let (s, z) = (along_wall(p), p.z);
    let (width, height, top) = BRICK;
    if z < top {
        let row = (z / height).floor();
        // Running bond: every other row shifted by half a brick.
        let shifted = s + if row as i64 % 2 == 0 {
            0.0
        } else {
            width / 2.0
        };
        let column = (shifted / width).floor();
        let (u, v) = (shifted / width - column, z / height - row);
        let joint = u < 0.05 || v < 0.13;
        if joint {
            return scale([0.78, 0.76, 0.72], 0.9 + 0.1 * fbm(p * 40.0, seed));
        }
        let tint = hash3(row as i64, column as i64, 3, seed);
        let base = mix([0.62, 0.25, 0.16], [0.75, 0.4, 0.26], tint);
        return scale(base, 0.85 + 0.2 * fbm(p * 25.0, seed.wrapping_add(37)));
    }
    let ([s0, s1], [z0, z1], (cell_w, cell_h)) = NOTICE;
    if (s0..s1).contains(&s) && (z0..z1).contains(&z) {
        return notice(s - s0, z1 - z, cell_w, cell_h, seed);
    }
    albedo(&Material::Wallpaper, p, seed)
}

/// White paper with lines of dark glyphs: each cell a 3×5 bitmap drawn from the
/// hash, with a blank column and row around it; every fourth cell a space.
fn notice(x: f64, y: f64, cell_w: f64, cell_h: f64, seed: u64) -> [f64; 3] {
    let paper = [0.93, 0.92, 0.88];
    let margin = 0.03;
    if x < margin || y < margin {
        return paper;
    }
    let (cx, cy) = (
        ((x - margin) / cell_w).floor(),
        ((y - margin) / cell_h).floor(),
    );
    let (u, v) = ((x - margin) / cell_w - cx, (y - margin) / cell_h - cy);
    let (bit_x, bit_y) = ((u * 4.0).floor() as i64, (v * 6.0).floor() as i64);
    if bit_x >= 3 || bit_y >= 5 || hash3(cx as i64, cy as i64, 5, seed) < 0.25 {
        return paper;
    }
    if hash3(cx as i64 * 8 + bit_x, cy as i64 * 8 + bit_y, 7, seed) < 0.45 {
        [0.12, 0.12, 0.15]
    } else {
        paper
    }
}

fn tiled_floor(p: DVec3, seed: u64) -> [f64; 3] {
    let ([x0, x1], [y0, y1]) = RUG;
    if (x0..x1).contains(&p.x) && (y0..y1).contains(&p.y) {
        return rug(p.x - x0, p.y - y0, x1 - x0, y1 - y0, seed);
    }
    let tile = 0.3;
    let (i, j) = ((p.x / tile).floor(), (p.y / tile).floor());
    let (u, v) = (p.x / tile - i, p.y / tile - j);
    if u < 0.025 || v < 0.025 {
        return [0.45, 0.44, 0.42];
    }
    let base = if (i + j).rem_euclid(2.0) < 0.5 {
        [0.82, 0.8, 0.76]
    } else {
        [0.58, 0.6, 0.62]
    };
    scale(base, 0.92 + 0.08 * fbm(p * 12.0, seed.wrapping_add(41)))
}

/// A rug `w`×`h` metres: a dark border with a fringe of thin stripes, and a
/// field of diamonds with a fine weave.
fn rug(x: f64, y: f64, w: f64, h: f64, seed: u64) -> [f64; 3] {
    let edge = x.min(y).min(w - x).min(h - y);
    let weave = 0.92 + 0.08 * ((x * 700.0).sin() * (y * 700.0).sin());
    let c = if edge < 0.08 {
        if (edge / 0.016).floor() as i64 % 2 == 0 {
            [0.2, 0.16, 0.3]
        } else {
            [0.85, 0.75, 0.45]
        }
    } else {
        let d = ((x - w / 2.0).abs() + (y - h / 2.0).abs()) / 0.12;
        match d.floor() as i64 % 3 {
            0 => [0.65, 0.15, 0.15],
            1 => [0.9, 0.82, 0.6],
            _ => [0.15, 0.3, 0.45],
        }
    };
    scale(
        c,
        weave * (0.95 + 0.05 * fbm(DVec3::new(x, y, 0.0) * 30.0, seed)),
    )
}

/// 0 → 1 → 0 over a ring period, with soft edges.
fn smooth_pulse(t: f64) -> f64 {
    let x = (t - 0.5).abs() * 2.0;
    1.0 - x * x * (3.0 - 2.0 * x)
}

/// Fixed, view-independent lighting: ambient, a sun, and a lamp under the ceiling.
pub fn shade(albedo: [f64; 3], p: DVec3, normal: DVec3) -> [f64; 3] {
    let sun = DVec3::new(0.35, -0.45, 0.82).normalize();
    let lamp = DVec3::new(0.4, 0.3, 2.3);
    let to_lamp = lamp - p;
    let d2 = to_lamp.length_squared();
    let lamp_term = normal.dot(to_lamp / d2.sqrt()).max(0.0) * 1.6 / (1.0 + d2);
    let light = 0.42 + 0.35 * normal.dot(sun).max(0.0) + lamp_term;
    albedo.map(|c| (c * light).clamp(0.0, 1.0))
}
