//! Where things stand in the room, drawn from the seed.

use super::Surfaces;
use super::shapes::MeshBuilder;
use super::texture::{Material, albedo, shade};
use glam::{DVec2, DVec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

pub const ROOM_HALF: f64 = 2.0;
pub const ROOM_HEIGHT: f64 = 2.6;
pub const TABLE_HEIGHT: f64 = 0.75;

/// The room's mesh under construction, with per-face materials and normals.
#[derive(Debug)]
pub struct Room {
    pub builder: MeshBuilder,
}

impl Room {
    /// The lit colour of face `face` at surface point `p`.
    pub fn surface_color(&self, face: usize, p: DVec3, texture_seed: u64) -> [f64; 3] {
        let b = &self.builder;
        shade(
            albedo(&b.face_material[face], p, texture_seed),
            p,
            b.face_normal[face],
        )
    }

    /// A colour per vertex (from the first face that uses it), for viewers of the mesh.
    pub fn vertex_colors(&self, texture_seed: u64) -> Vec<[u8; 3]> {
        let b = &self.builder;
        let mut face_of_vertex = vec![usize::MAX; b.positions.len()];
        for (f, face) in b.faces.iter().enumerate() {
            for &v in face {
                if face_of_vertex[v as usize] == usize::MAX {
                    face_of_vertex[v as usize] = f;
                }
            }
        }
        b.positions
            .iter()
            .zip(face_of_vertex)
            .map(|(p, f)| {
                if f == usize::MAX {
                    return [0, 0, 0];
                }
                let p = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
                self.surface_color(f, p, texture_seed).map(to_u8)
            })
            .collect()
    }
}

pub fn to_u8(c: f64) -> u8 {
    (c.clamp(0.0, 1.0) * 255.0).round() as u8
}

fn jitter_color(rng: &mut Pcg64, base: [f64; 3], amount: f64) -> [f64; 3] {
    base.map(|c| (c + rng.random_range(-amount..=amount)).clamp(0.0, 1.0))
}

pub fn build_room(seed: u64, with_table: bool, surfaces: Surfaces) -> Room {
    let (floor_material, wall_material) = match surfaces {
        Surfaces::Plain => (Material::WoodFloor, Material::Wallpaper),
        Surfaces::Fine => (Material::TiledFloor, Material::BrickWall),
    };
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut b = MeshBuilder::default();
    let (h, z) = (ROOM_HALF, ROOM_HEIGHT);
    let cells = 16;
    let wall_cells = 11;

    let floor = b.object("floor");
    b.grid(
        floor,
        floor_material,
        DVec3::new(-h, -h, 0.0),
        (DVec3::X * 2.0 * h, DVec3::Y * 2.0 * h),
        (cells, cells),
    );
    // Four walls facing inward, then the ceiling facing down.
    let walls = [
        (DVec3::new(-h, -h, 0.0), DVec3::Y * 2.0 * h),
        (DVec3::new(h, h, 0.0), -DVec3::Y * 2.0 * h),
        (DVec3::new(h, -h, 0.0), -DVec3::X * 2.0 * h),
        (DVec3::new(-h, h, 0.0), DVec3::X * 2.0 * h),
    ];
    for (origin, along) in walls {
        let wall = b.object("wall");
        b.grid(
            wall,
            wall_material,
            origin,
            (along, DVec3::Z * z),
            (cells, wall_cells),
        );
    }
    let ceiling = b.object("ceiling");
    b.grid(
        ceiling,
        Material::Ceiling,
        DVec3::new(-h, h, z),
        (DVec3::X * 2.0 * h, -DVec3::Y * 2.0 * h),
        (cells, cells),
    );

    let table_yaw = rng.random_range(-0.25..0.25);
    let (s, c) = f64::sin_cos(table_yaw);
    let table_frame =
        |local: DVec2| DVec2::new(c * local.x - s * local.y, s * local.x + c * local.y);
    let support_z = if with_table {
        let table = b.object("table");
        let wood = Material::Wood {
            base: jitter_color(&mut rng, [0.62, 0.42, 0.25], 0.06),
        };
        let top_half = DVec3::new(0.6, 0.4, 0.025);
        b.cuboid(
            table,
            wood,
            DVec3::new(0.0, 0.0, TABLE_HEIGHT - top_half.z),
            top_half,
            table_yaw,
            0.1,
        );
        let leg_half = DVec3::new(0.03, 0.03, (TABLE_HEIGHT - 2.0 * top_half.z) / 2.0);
        for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            let at = table_frame(DVec2::new(sx * 0.52, sy * 0.32));
            b.cuboid(
                table,
                wood,
                DVec3::new(at.x, at.y, leg_half.z),
                leg_half,
                table_yaw,
                0.1,
            );
        }
        TABLE_HEIGHT
    } else {
        0.0
    };

    // Three small objects in shuffled slots on the table top (or the floor).
    let mut slots = [
        DVec2::new(-0.36, -0.1),
        DVec2::new(0.0, 0.16),
        DVec2::new(0.34, -0.12),
    ];
    for i in (1..slots.len()).rev() {
        let j = rng.random_range(0..=i);
        slots.swap(i, j);
    }
    let place = |rng: &mut Pcg64, slot: DVec2| {
        let jitter = DVec2::new(rng.random_range(-0.05..0.05), rng.random_range(-0.05..0.05));
        table_frame(slot + jitter)
    };

    let at = place(&mut rng, slots[0]);
    let box_id = b.object("box");
    let checker = Material::Checker {
        a: jitter_color(&mut rng, [0.85, 0.3, 0.2], 0.08),
        b: jitter_color(&mut rng, [0.95, 0.9, 0.75], 0.04),
        size: 0.03,
    };
    let box_half = DVec3::new(0.09, 0.07, 0.06);
    let box_yaw = rng.random_range(0.0..std::f64::consts::PI);
    b.cuboid(
        box_id,
        checker,
        DVec3::new(at.x, at.y, support_z + box_half.z),
        box_half,
        box_yaw,
        0.03,
    );

    let at = place(&mut rng, slots[1]);
    let cup = b.object("cup");
    let stripes = Material::Stripes {
        a: jitter_color(&mut rng, [0.2, 0.35, 0.8], 0.08),
        b: [0.93, 0.93, 0.9],
        period: 0.025,
    };
    b.cylinder(
        cup,
        stripes,
        DVec3::new(at.x, at.y, support_z),
        0.045,
        0.11,
        32,
    );

    let at = place(&mut rng, slots[2]);
    let ball = b.object("ball");
    let radius = 0.08;
    let center = DVec3::new(at.x, at.y, support_z + radius);
    let segments = Material::Segments {
        center: center.to_array(),
        colors: [
            jitter_color(&mut rng, [0.9, 0.75, 0.1], 0.05),
            jitter_color(&mut rng, [0.15, 0.6, 0.25], 0.05),
            jitter_color(&mut rng, [0.8, 0.15, 0.45], 0.05),
        ],
    };
    b.sphere(ball, segments, center, radius, 16, 24);

    // A chair on one of the long sides, facing the table.
    let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    let chair_at = table_frame(DVec2::new(rng.random_range(-0.25..0.25), side * 0.78));
    let chair_yaw = table_yaw + rng.random_range(-0.3..0.3);
    build_chair(&mut b, &mut rng, chair_at, chair_yaw, side);

    // A bin on the floor towards one end of the table.
    let end = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    let bin_angle: f64 = rng.random_range(-0.5..0.5);
    let bin_at = DVec2::new(end * 1.05 * bin_angle.cos(), 1.05 * bin_angle.sin());
    let bin = b.object("bin");
    let metal = Material::Metal {
        base: jitter_color(&mut rng, [0.55, 0.58, 0.6], 0.05),
    };
    b.cylinder(
        bin,
        metal,
        DVec3::new(bin_at.x, bin_at.y, 0.0),
        0.15,
        0.35,
        32,
    );

    Room { builder: b }
}

fn build_chair(b: &mut MeshBuilder, rng: &mut Pcg64, at: DVec2, yaw: f64, side: f64) {
    let chair = b.object("chair");
    let fabric = Material::Fabric {
        base: jitter_color(rng, [0.3, 0.45, 0.55], 0.08),
    };
    let frame = Material::Wood {
        base: [0.35, 0.25, 0.18],
    };
    let (s, c) = yaw.sin_cos();
    let local = |x: f64, y: f64| DVec2::new(at.x + c * x - s * y, at.y + s * x + c * y);
    let seat_z = 0.45;
    let seat_half = DVec3::new(0.21, 0.2, 0.03);
    b.cuboid(
        chair,
        fabric,
        DVec3::new(at.x, at.y, seat_z - seat_half.z),
        seat_half,
        yaw,
        0.05,
    );
    let leg_half = DVec3::new(0.02, 0.02, (seat_z - 2.0 * seat_half.z) / 2.0);
    for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        let p = local(sx * 0.18, sy * 0.17);
        b.cuboid(
            chair,
            frame,
            DVec3::new(p.x, p.y, leg_half.z),
            leg_half,
            yaw,
            0.1,
        );
    }
    // The back stands on the side away from the table.
    let back = local(0.0, side * 0.18);
    let back_half = DVec3::new(0.21, 0.025, 0.22);
    b.cuboid(
        chair,
        fabric,
        DVec3::new(back.x, back.y, seat_z + back_half.z),
        back_half,
        yaw,
        0.05,
    );
}
