//! `--export-volume`: the liquid of exported frames as OpenVDB volumes ([`super::vdb`]), one
//! `volume_NNNNNN.vdb` a frame that Blender and Houdini open, holding these grids:
//!
//! - `surface`, a narrow-band level set: signed distance in metres, negative inside, the `class`
//!   `level set` and a background of the band's half width. It comes from the very field the
//!   surface meshes are cut from ([`super::surface`]): splashsurf's SPH volume fraction of the
//!   particle positions, `phi(x) = sum_j (m / rho_j) W(x - x_j)`, whose level `threshold` (0.6 by
//!   default) is the surface. splashsurf's own density map samples it on the voxels; a voxel with a
//!   neighbour across the level gets its distance from the crossings on its edges (placed by linear
//!   interpolation, as marching cubes places its vertices: `1 / d^2 = sum over axes 1 / d_a^2`),
//!   and fast marching (Sethian's first-order upwind update) carries the distance out to the
//!   band's edge, inside and out. Voxels past the band hold minus or plus the band's half width,
//!   inactive, as do the tiles that cover regions wholly inside or outside.
//! - `density`, a fog volume: `phi` itself (about 1 in the liquid, falling to 0 over a kernel's
//!   reach outside it), active where it is not 0.
//! - `velocity` (`--volume-velocity`), a vector grid (`vector_type` `contravariant relative`): the
//!   particles' velocity, m/s, SPH-interpolated on the density's active voxels with Shepard's
//!   normalisation, `sum_j V_j v_j W / sum_j V_j W` (`V_j = m / rho_j`), summed by the same loop.
//!
//! Voxel `(i, j, k)` sits at `voxel_size * (i, j, k)` in the simulation's coordinates (metres, y up):
//! every frame's grids share one lattice. The grids are built on worker threads beside the
//! simulation ([`VolumeQueue`], a [`FileQueue`] as the surface meshes have).

use super::queue::{FileQueue, FileWords, FinishedFile};
use super::surface::{SurfaceOverrides, SurfaceSettings};
use super::vdb::{self, AnyGrid, Coord, Grid, GridClass, Leaf, Meta, Tree, LEAF_LOG2, LEAF_SIZE};
use super::{check_every, FrameDir, FrameKind};
use crate::sim::Scene;
use anyhow::{bail, Result};
use glam::Vec3;
use rayon::prelude::*;
use splashsurf_lib::nalgebra::Vector3;
use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};
use std::hash::{BuildHasherDefault, Hasher};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The volumes of `--export-volume`: `volume_NNNNNN.vdb`.
pub const VOLUME_FRAMES: FrameKind = FrameKind {
    flag: "--export-volume",
    prefix: "volume_",
    extensions: &["vdb"],
    companions: &[],
    noun: ("volume", "volumes"),
};

/// The level set's band: voxels on each side of the surface (OpenVDB's `LEVEL_SET_HALF_WIDTH`).
pub const DEFAULT_BAND: f32 = 3.0;
/// The grids' names in the file: Blender's volume shader reads `density` by default, and its
/// motion blur `velocity`.
pub const SURFACE_GRID: &str = "surface";
pub const DENSITY_GRID: &str = "density";
pub const VELOCITY_GRID: &str = "velocity";

/// Bytes a frame's export holds at its peak per voxel the liquid fills (the field's blocks, the
/// distances, the grids and the file's bytes): about 45 measured on the dam break's first frame
/// (164 MB over the run's own for its 3.6 million voxels of liquid; docs/export.md, "Volumes"),
/// doubled for what a splash adds.
const BYTES_PER_VOXEL: f64 = 100.0;
/// The same, more, with `--volume-velocity` (the three sums, the values, the grid and its bytes:
/// about 45 more measured).
const VELOCITY_BYTES_PER_VOXEL: f64 = 60.0;

/// The file formats of `--volume-format`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum VolumeFormat {
    /// OpenVDB (file format 224): Blender, Houdini, and anything on the OpenVDB library.
    Vdb,
}

impl VolumeFormat {
    pub fn extension(self) -> &'static str {
        match self {
            VolumeFormat::Vdb => "vdb",
        }
    }
}

/// The volumes' parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VolumeSettings {
    /// The field: the surface meshes' particle radius, smoothing length, threshold and rest
    /// density (their marching-cubes cell is not used).
    pub field: SurfaceSettings,
    /// The voxel's edge, m (`--volume-voxel-size`).
    pub voxel_size: f32,
    /// The level set's band on each side of the surface, in voxels (`--volume-band`).
    pub band: f32,
    /// Write the `velocity` grid (`--volume-velocity`).
    pub velocity: bool,
    /// Values as 16-bit halves (`--volume-half`).
    pub half: bool,
}

/// The command line's choices for the volumes; `None` keeps the default.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct VolumeOverrides {
    pub voxel_size: Option<f32>,
    pub band: Option<f32>,
    pub velocity: bool,
    pub half: bool,
}

impl VolumeSettings {
    /// The defaults for `scene` (the voxel the surface meshes' marching-cubes cell, a particle
    /// radius; a band of 3 voxels), with the overrides applied and checked: `workers` frames built
    /// at once must fit in the memory this machine has available.
    pub fn for_scene(
        scene: &Scene,
        surface: SurfaceOverrides,
        volume: VolumeOverrides,
        workers: usize,
    ) -> Result<VolumeSettings> {
        let field = SurfaceSettings::for_scene(scene, surface)?;
        let settings = VolumeSettings {
            field,
            voxel_size: volume.voxel_size.unwrap_or(field.particle_radius),
            band: volume.band.unwrap_or(DEFAULT_BAND),
            velocity: volume.velocity,
            half: volume.half,
        };
        for (flag, value, unit) in [
            ("--volume-voxel-size", settings.voxel_size, "m"),
            ("--volume-band", settings.band, "voxels"),
        ] {
            if !(value.is_finite() && value > 0.0) {
                bail!("{flag} {value} must be a positive number ({unit})");
            }
        }
        if settings.band < 1.0 {
            bail!(
                "--volume-band {} is narrower than a voxel: the voxels next to the surface would fall \
                 outside the level set's band; give 1 or more (3, the default, is OpenVDB's own)",
                settings.band
            );
        }
        let longest = scene.grid_res.iter().copied().max().unwrap_or(0) as f64 * f64::from(scene.dx);
        let per_axis = longest / f64::from(settings.voxel_size);
        if per_axis > f64::from(1u32 << 28) {
            bail!(
                "--volume-voxel-size {} m would cut the {longest} m domain into {per_axis:.3e} voxels per \
                 axis, past what a grid's coordinates hold; give a larger --volume-voxel-size",
                settings.voxel_size
            );
        }
        if let Some(available) = available_memory() {
            let needed = settings.memory_needed(scene, workers);
            if needed > available as f64 {
                let fits = f64::from(settings.voxel_size) * (needed / available as f64).cbrt();
                bail!(
                    "--volume-voxel-size {} m would need at least {:.1} GiB of memory for the volumes \
                     ({:.3e} voxels of liquid a frame, {workers} frames built at once), and this machine has \
                     {:.1} GiB available; give a larger --volume-voxel-size ({:.2e} m or more fits)",
                    settings.voxel_size,
                    needed / GIB,
                    settings.liquid_voxels(scene),
                    available as f64 / GIB,
                    fits * 1.05
                );
            }
        }
        Ok(settings)
    }

    /// The band's half width in metres: the level set's background.
    pub fn band_width(&self) -> f32 {
        self.band * self.voxel_size
    }

    /// Voxels the scene's liquid fills at rest (its particles' share of the spawn lattice; the
    /// capacity, for a scene whose emitters fill it).
    pub fn liquid_voxels(&self, scene: &Scene) -> f64 {
        let particles = scene.num_particles.max(scene.slots()) as f64;
        let spacing = f64::from(scene.dx) / f64::from(scene.particles_per_axis.max(1));
        particles * (spacing / f64::from(self.voxel_size)).powi(3)
    }

    /// Bytes `workers` frames' grids take while they are built, at the least: the liquid at rest
    /// (a splash covers more voxels).
    pub fn memory_needed(&self, scene: &Scene, workers: usize) -> f64 {
        let per_voxel = BYTES_PER_VOXEL
            + if self.velocity {
                VELOCITY_BYTES_PER_VOXEL
            } else {
                0.0
            };
        self.liquid_voxels(scene) * per_voxel * workers.max(1) as f64
    }

    /// One line for the user: what the volumes hold and how they are sampled.
    pub fn describe(&self) -> String {
        format!(
            "voxels of {:.4e} m, a band of {} voxels ({:.4e} m) on each side, grids {}{} as {}; \
             the field: {}",
            self.voxel_size,
            self.band,
            self.band_width(),
            [SURFACE_GRID, DENSITY_GRID].join(", "),
            if self.velocity { ", velocity" } else { "" },
            if self.half {
                "16-bit halves"
            } else {
                "32-bit floats"
            },
            self.field.describe_field()
        )
    }
}

const GIB: f64 = (1u64 << 30) as f64;

/// The memory this machine has available now (Linux's `MemAvailable`), bytes; `None` where it
/// cannot be read.
pub fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// A frame's grids, as written.
#[derive(Debug, Clone)]
pub struct Volumes {
    pub surface: Grid<f32>,
    pub density: Grid<f32>,
    pub velocity: Option<Grid<[f32; 3]>>,
}

impl Volumes {
    fn grids(&self) -> Vec<&dyn AnyGrid> {
        let mut grids: Vec<&dyn AnyGrid> = vec![&self.surface, &self.density];
        if let Some(v) = &self.velocity {
            grids.push(v);
        }
        grids
    }
}

/// A hasher for voxel and block coordinates (FxHash's multiply-rotate): the fast marching looks
/// blocks up millions of times a frame, and SipHash's resistance to chosen keys buys nothing here.
#[derive(Default, Clone, Copy)]
struct CoordHasher(u64);

impl Hasher for CoordHasher {
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(4) {
            let mut word = [0u8; 4];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u32(u32::from_le_bytes(word));
        }
    }
    fn write_u32(&mut self, i: u32) {
        self.0 = (self.0.rotate_left(5) ^ u64::from(i)).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn write_usize(&mut self, i: usize) {
        self.write_u32(i as u32);
    }
    fn finish(&self) -> u64 {
        self.0
    }
}

type CoordMap<V> = HashMap<Coord, V, BuildHasherDefault<CoordHasher>>;

/// Voxel values in 8^3 blocks, by the blocks' origins.
struct Blocks<T> {
    index: CoordMap<usize>,
    origins: Vec<Coord>,
    data: Vec<Box<[T; LEAF_SIZE]>>,
    fill: T,
}

impl<T: Copy> Blocks<T> {
    fn new(fill: T) -> Blocks<T> {
        Blocks {
            index: CoordMap::default(),
            origins: Vec::new(),
            data: Vec::new(),
            fill,
        }
    }

    fn get(&self, ijk: Coord) -> T {
        match self.index.get(&vdb::node_origin(ijk, LEAF_LOG2)) {
            Some(&b) => self.data[b][vdb::leaf_offset(ijk)],
            None => self.fill,
        }
    }

    /// The block at `origin`, made (all `fill`) where it is missing.
    fn block(&mut self, origin: Coord) -> usize {
        let (data, origins, fill) = (&mut self.data, &mut self.origins, self.fill);
        *self.index.entry(origin).or_insert_with(|| {
            data.push(Box::new([fill; LEAF_SIZE]));
            origins.push(origin);
            data.len() - 1
        })
    }
}

/// The six face neighbours' offsets, by axis: -x, +x, -y, +y, -z, +z.
const FACES: [Coord; 6] = [
    [-1, 0, 0],
    [1, 0, 0],
    [0, -1, 0],
    [0, 1, 0],
    [0, 0, -1],
    [0, 0, 1],
];

fn add(a: Coord, b: Coord) -> Coord {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// The field `phi` sampled on the voxels, and the velocity interpolated there.
struct Field {
    phi: Blocks<f32>,
    /// By the same blocks as `phi` where the velocity is asked for.
    velocity: Option<Vec<Box<[[f32; 3]; LEAF_SIZE]>>>,
}

/// A chunk's blocks: origin, `phi`, and the velocity where it is asked for.
type ChunkBlocks = Vec<(Coord, Box<[f32; LEAF_SIZE]>, Option<Box<[[f32; 3]; LEAF_SIZE]>>)>;

/// Voxels per axis of the dense chunks the field is sampled in (a multiple of a leaf's 8).
const CHUNK: i32 = 32;

/// Samples the surface meshes' field on the voxels of edge `h`, through splashsurf's own code: its
/// neighbour search and particle densities, then the loop that fills the mesher's dense subdomains
/// with the field (`density_grid_loop_auto`, vectorised where the CPU can), here over chunks of
/// 32^3 voxels on the global lattice, in parallel, keeping the 8^3 blocks the liquid reaches.
/// With `velocities`, the same loop sums `V_j v_j W` a component at a time (handed the density
/// `rho_j / v_j`, so that its `m / rho` weight is `V_j v_j`; a component 0 gives `rho / 0 = inf`
/// and a weight of 0), and the sums over `phi = sum V_j W` are Shepard's interpolation.
fn sample_field(positions: &[Vec3], velocities: Option<&[Vec3]>, settings: &VolumeSettings) -> Result<Field> {
    use splashsurf_lib::UniformGrid;
    let h = settings.voxel_size;
    let params = settings.field.splashsurf_parameters(h);
    let support = params.compact_support_radius;
    let rest_mass =
        splashsurf_lib::kernel::Volume::cube_particle(params.particle_radius) * params.rest_density;
    let points: Vec<Vector3<f32>> = positions.iter().map(|p| Vector3::new(p.x, p.y, p.z)).collect();
    let (lo, hi) = positions.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    // The lattice the chunks tile: from a multiple of CHUNK voxels, past the kernel's reach of
    // every particle.
    let reach = (support / h).ceil() + 2.0;
    let first = ((lo / h).floor() - Vec3::splat(reach))
        .to_array()
        .map(|c| (c as i32).div_euclid(CHUNK) * CHUNK);
    let last = ((hi / h).ceil() + Vec3::splat(reach))
        .to_array()
        .map(|c| c as i32);
    let chunks_per_axis: [i32; 3] = std::array::from_fn(|a| (last[a] - first[a]) / CHUNK + 1);
    let global = UniformGrid::<i64, f32>::new(
        &Vector3::new(first[0] as f32 * h, first[1] as f32 * h, first[2] as f32 * h),
        &chunks_per_axis.map(|n| i64::from(n * CHUNK)),
        h,
    )
    .map_err(|e| anyhow::anyhow!("the volume's grid: {e}"))?;
    let mut neighbours =
        splashsurf_lib::neighborhood_search::search::<i64, f32>(global.aabb(), &points, support, true);
    // The parallel search lists neighbours in an order that varies with the threads; sorted, each
    // density sums in one order and the same particles give the same grids, to the bit.
    neighbours.par_iter_mut().for_each(|list| list.sort_unstable());
    let densities = splashsurf_lib::density_map::compute_particle_densities::<i64, f32>(
        &points,
        &neighbours,
        support,
        rest_mass,
        true,
    );
    drop(neighbours);
    // Each chunk's particles: those within the kernel's reach (and a voxel) of its voxels.
    let mut chunks: CoordMap<Vec<u32>> = CoordMap::default();
    let margin = support * 1.01 + h;
    for (n, p) in positions.iter().enumerate() {
        let range = |x: f32, a: usize| {
            ((x / h).floor() as i32 - first[a])
                .div_euclid(CHUNK)
                .clamp(0, chunks_per_axis[a] - 1)
        };
        let (c0, c1) = (
            std::array::from_fn::<i32, 3, _>(|a| range(p[a] - margin, a)),
            std::array::from_fn::<i32, 3, _>(|a| range(p[a] + margin, a)),
        );
        for i in c0[0]..=c1[0] {
            for j in c0[1]..=c1[1] {
                for k in c0[2]..=c1[2] {
                    chunks.entry([i, j, k]).or_default().push(n as u32);
                }
            }
        }
    }
    let chunks: Vec<(Coord, Vec<u32>)> = chunks.into_iter().collect();
    let kernel = splashsurf_lib::kernel::CubicSplineKernel::new(support);
    let cube_radius = (support / h).ceil() as i64;
    let side = (CHUNK + 1) as usize;
    let blocks: ChunkBlocks = chunks
        .par_iter()
        .map(|(chunk, ids)| -> Result<ChunkBlocks> {
            let min = global.point_coordinates_indices(
                i64::from(chunk[0] * CHUNK),
                i64::from(chunk[1] * CHUNK),
                i64::from(chunk[2] * CHUNK),
            );
            let grid = UniformGrid::<i64, f32>::new(&min, &[i64::from(CHUNK); 3], h)
                .map_err(|e| anyhow::anyhow!("the volume's grid: {e}"))?;
            let ps: Vec<Vector3<f32>> = ids.iter().map(|&n| points[n as usize]).collect();
            let splat = |ds: &[f32]| {
                let mut values = vec![0.0f32; side * side * side];
                splashsurf_lib::dense_subdomains::density_grid_loop_auto(
                    &mut values,
                    &ps,
                    ds,
                    &grid,
                    &chunk.map(i64::from),
                    &global,
                    cube_radius,
                    support * support * 1.01,
                    rest_mass,
                    &kernel,
                );
                values
            };
            let ds: Vec<f32> = ids.iter().map(|&n| densities[n as usize]).collect();
            let values = splat(&ds);
            let sums = velocities.map(|v| {
                [0, 1, 2].map(|a| {
                    let ds: Vec<f32> = ids
                        .iter()
                        .map(|&n| densities[n as usize] / v[n as usize][a])
                        .collect();
                    splat(&ds)
                })
            });
            // The chunk's voxels are its points 0..CHUNK on each axis (the last layer is the next
            // chunk's first), in leaves of 8^3.
            let per_axis = CHUNK / 8;
            let mut out = Vec::new();
            for b in 0..per_axis * per_axis * per_axis {
                let local =
                    [b / (per_axis * per_axis), (b / per_axis) % per_axis, b % per_axis].map(|c| c * 8);
                let at = |n: usize| {
                    let [i, j, k] = vdb::leaf_coord(local, n).map(|c| c as usize);
                    (i * side + j) * side + k
                };
                let block: Box<[f32; LEAF_SIZE]> = Box::new(std::array::from_fn(|n| values[at(n)]));
                if block.iter().any(|&v| v != 0.0) {
                    let origin = std::array::from_fn(|a| first[a] + chunk[a] * CHUNK + local[a]);
                    let velocity = sums.as_ref().map(|sums| {
                        Box::new(std::array::from_fn(|n| match block[n] {
                            0.0 => [0.0; 3],
                            phi => sums.each_ref().map(|sum| sum[at(n)] / phi),
                        }))
                    });
                    out.push((origin, block, velocity));
                }
            }
            Ok(out)
        })
        .collect::<Result<Vec<_>>>()?
        .into_iter()
        .flatten()
        .collect();
    let mut phi = Blocks::new(0.0f32);
    let mut velocity = velocities.map(|_| Vec::with_capacity(blocks.len()));
    for (origin, block, v) in blocks {
        phi.index.insert(origin, phi.data.len());
        phi.origins.push(origin);
        phi.data.push(block);
        if let (Some(all), Some(v)) = (velocity.as_mut(), v) {
            all.push(v);
        }
    }
    Ok(Field { phi, velocity })
}

/// A voxel waiting in the fast marching's heap, the nearest first.
#[derive(PartialEq)]
struct Trial(f32, Coord);

impl Eq for Trial {}

impl PartialOrd for Trial {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Trial {
    fn cmp(&self, other: &Self) -> Ordering {
        other.0.total_cmp(&self.0).then_with(|| other.1.cmp(&self.1))
    }
}

/// Distances being marched: a value per voxel, and whether it is final.
struct Distances(Blocks<(f32, bool)>);

impl Distances {
    fn get(&self, ijk: Coord) -> (f32, bool) {
        self.0.get(ijk)
    }

    fn known_value(&self, ijk: Coord) -> f32 {
        match self.get(ijk) {
            (d, true) => d,
            _ => f32::INFINITY,
        }
    }

    fn set(&mut self, ijk: Coord, d: f32, known: bool) {
        let b = self.0.block(vdb::node_origin(ijk, LEAF_LOG2));
        self.0.data[b][vdb::leaf_offset(ijk)] = (d, known);
    }

    /// The first-order upwind solution of |grad d| = 1 at `ijk` from its final neighbours
    /// (Sethian's fast marching update), voxels of edge `h`.
    fn update(&self, ijk: Coord, h: f32) -> f32 {
        let mut a = [0.0f32; 3];
        for (axis, a) in a.iter_mut().enumerate() {
            *a = self
                .known_value(add(ijk, FACES[2 * axis]))
                .min(self.known_value(add(ijk, FACES[2 * axis + 1])));
        }
        a.sort_by(f32::total_cmp);
        let mut u = a[0] + h;
        if u > a[1] {
            let gap = a[0] - a[1];
            u = 0.5 * (a[0] + a[1] + (2.0 * h * h - gap * gap).max(0.0).sqrt());
            if u > a[2] {
                let s = a[0] + a[1] + a[2];
                let q = a[0] * a[0] + a[1] * a[1] + a[2] * a[2] - h * h;
                u = (s + (s * s - 3.0 * q).max(0.0).sqrt()) / 3.0;
            }
        }
        u
    }
}

/// The distance to the level `threshold` of `phi` at each voxel that has a face neighbour across
/// it: on each axis, the nearer crossing placed by linear interpolation; then `1 / d^2 = sum over
/// the axes with a crossing of 1 / d_a^2` (the distance to the plane through them).
fn interface(phi: &Blocks<f32>, threshold: f32, h: f32) -> Vec<(Coord, f32)> {
    // The blocks of the field and their face neighbours: a voxel outside every block (phi = 0) may
    // sit next to one inside.
    let mut origins: Vec<Coord> = phi.origins.clone();
    for &o in &phi.origins {
        for f in FACES {
            let n = add(o, f.map(|c| c * 8));
            if !phi.index.contains_key(&n) {
                origins.push(n);
            }
        }
    }
    origins.sort_unstable();
    origins.dedup();
    origins
        .par_iter()
        .flat_map_iter(|&origin| {
            let block = phi.index.get(&origin).map(|&b| &phi.data[b]);
            let at = move |ijk: Coord| match block {
                Some(block) if vdb::node_origin(ijk, LEAF_LOG2) == origin => block[vdb::leaf_offset(ijk)],
                _ => phi.get(ijk),
            };
            (0..LEAF_SIZE).filter_map(move |n| {
                let ijk = vdb::leaf_coord(origin, n);
                let f0 = at(ijk) - threshold;
                let inside = f0 > 0.0;
                let mut sum = 0.0f32;
                let mut crossed = false;
                for axis in 0..3 {
                    let mut nearest = f32::INFINITY;
                    for f in [FACES[2 * axis], FACES[2 * axis + 1]] {
                        let f1 = at(add(ijk, f)) - threshold;
                        if (f1 > 0.0) != inside {
                            nearest = nearest.min((f0 / (f0 - f1)).clamp(0.0, 1.0) * h);
                        }
                    }
                    if nearest.is_finite() {
                        crossed = true;
                        if nearest == 0.0 {
                            return Some((ijk, 0.0));
                        }
                        sum += 1.0 / (nearest * nearest);
                    }
                }
                crossed.then(|| (ijk, 1.0 / sum.sqrt()))
            })
        })
        .collect()
}

/// The narrow-band level set of `phi` at `threshold`: signed distance, negative inside, clamped to
/// the band's half width `band` (m), voxels of edge `h`.
fn level_set(phi: &Blocks<f32>, threshold: f32, h: f32, band: f32) -> Tree<f32> {
    let inside = |ijk: Coord| phi.get(ijk) > threshold;
    let mut dist = Distances(Blocks::new((f32::INFINITY, false)));
    let seeds = interface(phi, threshold, h);
    for &(ijk, d) in &seeds {
        dist.set(ijk, d.min(band), true);
    }
    let mut heap = BinaryHeap::new();
    let neighbours = |dist: &mut Distances, heap: &mut BinaryHeap<Trial>, ijk: Coord| {
        for f in FACES {
            let n = add(ijk, f);
            let (d, known) = dist.get(n);
            if !known {
                let u = dist.update(n, h);
                if u < d {
                    dist.set(n, u, false);
                    heap.push(Trial(u, n));
                }
            }
        }
    };
    for &(ijk, _) in &seeds {
        neighbours(&mut dist, &mut heap, ijk);
    }
    while let Some(Trial(d, ijk)) = heap.pop() {
        if d >= band {
            break;
        }
        match dist.get(ijk) {
            (_, true) => continue,
            (current, false) if d > current => continue,
            _ => {}
        }
        dist.set(ijk, d, true);
        neighbours(&mut dist, &mut heap, ijk);
    }
    let mut tree = Tree::new(band);
    for (b, &origin) in dist.0.origins.iter().enumerate() {
        let cells = &dist.0.data[b];
        if !cells.iter().any(|&(_, known)| known) {
            continue;
        }
        let mut leaf = Leaf::filled(band);
        for (n, &(d, known)) in cells.iter().enumerate() {
            let sign = if inside(vdb::leaf_coord(origin, n)) {
                -1.0
            } else {
                1.0
            };
            if known {
                leaf.set(n, sign * d.min(band), true);
            } else {
                leaf.set(n, sign * band, false);
            }
        }
        tree.insert_leaf(origin, leaf);
    }
    inside_tiles(&mut tree, phi, &inside, -band);
    tree
}

/// Marks the regions of a level set with no leaf that lie inside the liquid (`inside`), at every
/// level of the tree, with the inactive value `value`: a region without a voxel in the band lies
/// wholly on one side, so one voxel tells which.
fn inside_tiles(tree: &mut Tree<f32>, phi: &Blocks<f32>, inside: &dyn Fn(Coord) -> bool, value: f32) {
    let leaves: Vec<Coord> = tree.leaves().map(|(&o, _)| o).collect();
    let mut node4s: Vec<Coord> = leaves.iter().map(|&o| vdb::node_origin(o, 7)).collect();
    node4s.sort_unstable();
    node4s.dedup();
    let mut node5s: Vec<Coord> = node4s.iter().map(|&o| vdb::node_origin(o, 12)).collect();
    node5s.sort_unstable();
    node5s.dedup();
    let has_leaf: std::collections::HashSet<Coord> = leaves.into_iter().collect();
    let has_node4: std::collections::HashSet<Coord> = node4s.iter().copied().collect();
    let slots = |origin: Coord, total: i32, child: i32| {
        let n = 1 << (total - child);
        (0..n * n * n).map(move |s| {
            [
                origin[0] + ((s / (n * n)) << child),
                origin[1] + (((s / n) % n) << child),
                origin[2] + ((s % n) << child),
            ]
        })
    };
    for &n4 in &node4s {
        for o in slots(n4, 7, 3) {
            if !has_leaf.contains(&o) && inside(o) {
                tree.set_tile(o, 3, value);
            }
        }
    }
    for &n5 in &node5s {
        for o in slots(n5, 12, 7) {
            if !has_node4.contains(&o) && inside(o) {
                tree.set_tile(o, 7, value);
            }
        }
    }
    // The root's regions the liquid reaches and no leaf does.
    let mut roots: Vec<Coord> = phi.origins.iter().map(|&o| vdb::node_origin(o, 12)).collect();
    roots.sort_unstable();
    roots.dedup();
    for o in roots {
        if node5s.binary_search(&o).is_err() && inside(o) {
            tree.set_tile(o, 12, value);
        }
    }
}

/// The density grid's tree: `phi`, active where it is not 0.
fn density_tree(phi: &Blocks<f32>) -> Tree<f32> {
    let mut tree = Tree::new(0.0);
    for (b, &origin) in phi.origins.iter().enumerate() {
        let mut leaf = Leaf::filled(0.0);
        for (n, &v) in phi.data[b].iter().enumerate() {
            leaf.set(n, v, v != 0.0);
        }
        if leaf.active_count() > 0 {
            tree.insert_leaf(origin, leaf);
        }
    }
    tree
}

/// The velocity grid's tree: the velocity on the density's active voxels.
fn velocity_tree(phi: &Blocks<f32>, velocity: &[Box<[[f32; 3]; LEAF_SIZE]>]) -> Tree<[f32; 3]> {
    let mut tree = Tree::new([0.0; 3]);
    for (b, &origin) in phi.origins.iter().enumerate() {
        let mut leaf = Leaf::filled([0.0; 3]);
        for (n, &v) in phi.data[b].iter().enumerate() {
            leaf.set(n, velocity[b][n], v != 0.0);
        }
        if leaf.active_count() > 0 {
            tree.insert_leaf(origin, leaf);
        }
    }
    tree
}

/// The grids of particles at `positions`, with their `velocities` where the settings ask for the
/// velocity grid.
pub fn build(positions: &[Vec3], velocities: Option<&[Vec3]>, settings: &VolumeSettings) -> Result<Volumes> {
    let h = settings.voxel_size;
    let band = settings.band_width();
    let grid = |name: &str, class, tree| Grid {
        name: name.into(),
        class,
        vector_type: None,
        voxel_size: f64::from(h),
        half: settings.half,
        tree,
    };
    if positions.is_empty() {
        return Ok(Volumes {
            surface: grid(SURFACE_GRID, GridClass::LevelSet, Tree::new(band)),
            density: grid(DENSITY_GRID, GridClass::FogVolume, Tree::new(0.0)),
            velocity: settings.velocity.then(|| Grid {
                name: VELOCITY_GRID.into(),
                class: GridClass::Unknown,
                vector_type: Some("contravariant relative"),
                voxel_size: f64::from(h),
                half: settings.half,
                tree: Tree::new([0.0; 3]),
            }),
        });
    }
    if settings.velocity && velocities.is_none() {
        bail!("the velocity grid needs the particles' velocities");
    }
    let field = sample_field(positions, velocities.filter(|_| settings.velocity), settings)?;
    let surface = level_set(&field.phi, settings.field.threshold, h, band);
    let density = density_tree(&field.phi);
    let velocity = field.velocity.map(|v| Grid {
        name: VELOCITY_GRID.into(),
        class: GridClass::Unknown,
        vector_type: Some("contravariant relative"),
        voxel_size: f64::from(h),
        half: settings.half,
        tree: velocity_tree(&field.phi, &v),
    });
    Ok(Volumes {
        surface: grid(SURFACE_GRID, GridClass::LevelSet, surface),
        density: grid(DENSITY_GRID, GridClass::FogVolume, density),
        velocity,
    })
}

/// The particles of one exported frame, on their way to a worker.
pub struct VolumeJob {
    pub frame: u64,
    /// The file's metadata `mpm_comment` (frame, time, scene).
    pub comment: String,
    pub positions: Vec<Vec3>,
    /// The particles' velocities, where the settings ask for the velocity grid.
    pub velocities: Option<Vec<Vec3>>,
}

/// Writes `volume_NNNNNN.vdb` files into one directory.
pub struct VolumeExporter {
    frames: FrameDir,
    every: u64,
    format: VolumeFormat,
    settings: VolumeSettings,
}

impl VolumeExporter {
    /// Opens `dir` as [`FrameDir::open`] says (refusing files of an earlier run unless
    /// `overwrite`); `every` is `--every`.
    pub fn new(
        dir: &Path,
        every: u64,
        format: VolumeFormat,
        settings: VolumeSettings,
        overwrite: bool,
    ) -> Result<VolumeExporter> {
        check_every(every)?;
        Ok(VolumeExporter {
            frames: FrameDir::open(dir, VOLUME_FRAMES, format.extension(), overwrite)?,
            every,
            format,
            settings,
        })
    }

    /// `--every`.
    pub fn every(&self) -> u64 {
        self.every
    }

    pub fn wants(&self, frame: u64) -> bool {
        frame % self.every == 0
    }

    pub fn path_of(&self, frame: u64) -> PathBuf {
        self.frames.path_of(frame)
    }

    pub fn dir(&self) -> &Path {
        self.frames.dir()
    }

    /// Where the volumes go, for the user: "vdb in out/volumes".
    pub fn destination(&self) -> String {
        format!("{} in {}", self.format.extension(), self.dir().display())
    }

    pub fn format(&self) -> VolumeFormat {
        self.format
    }

    pub fn settings(&self) -> &VolumeSettings {
        &self.settings
    }

    /// One line for the user about the volumes `--overwrite` removed, or `None`.
    pub fn removed_note(&self) -> Option<String> {
        self.frames.removed_note()
    }

    /// Builds and writes one frame's volume, here and now.
    pub fn export(&self, job: &VolumeJob) -> Result<VolumeDone> {
        let start = Instant::now();
        let volumes = build(&job.positions, job.velocities.as_deref(), &self.settings)?;
        let built = Instant::now();
        let metadata = [
            (
                "creator",
                Meta::String(format!("mpm {}", env!("CARGO_PKG_VERSION"))),
            ),
            ("mpm_comment", Meta::String(job.comment.clone())),
            ("mpm_frame", Meta::Int64(job.frame as i64)),
            ("mpm_volume", Meta::String(self.settings.describe())),
        ];
        let path = self.frames.write(job.frame, |out| {
            vdb::write(out, &volumes.grids(), &metadata)?;
            Ok(())
        })?;
        Ok(VolumeDone {
            frame: job.frame,
            path,
            band: volumes.surface.tree.active_voxel_count(),
            liquid: volumes.density.tree.active_voxel_count(),
            build: built - start,
            write: built.elapsed(),
        })
    }
}

/// One finished volume.
#[derive(Debug, Clone)]
pub struct VolumeDone {
    pub frame: u64,
    pub path: PathBuf,
    /// Active voxels of the level set (the band) and of the density (the liquid).
    pub band: u64,
    pub liquid: u64,
    /// Wall time of building the grids.
    pub build: Duration,
    /// Wall time of writing the file.
    pub write: Duration,
}

impl FinishedFile for VolumeDone {
    const WORDS: FileWords = FileWords {
        what: "volume",
        files: VOLUME_FRAMES.noun,
        short: VOLUME_FRAMES.noun,
        size: "active voxels",
        stages: ["grids", "writing"],
    };

    fn path(&self) -> &Path {
        &self.path
    }

    /// Active voxels of every grid written, summed.
    fn size(&self) -> u64 {
        self.band + self.liquid
    }

    fn stages(&self) -> [Duration; 2] {
        [self.build, self.write]
    }

    fn contents(&self) -> String {
        format!("{} voxels in the band, {} in the liquid", self.band, self.liquid)
    }
}

/// The volumes' worker threads ([`VolumeExporter::export`] on each job) and the bounded queue that
/// feeds them.
pub type VolumeQueue = FileQueue<VolumeExporter, VolumeJob, VolumeDone>;
