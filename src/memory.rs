//! Memory preflight (`cirrus render --memory-limit`): an estimate of a
//! render's peak resident memory, made from the loaded scene and the VDB grid
//! tables before anything large is built, and a check that refuses the
//! render with that estimate instead of letting the OOM killer end it.
//!
//! The estimate is a sum of parts, each the part's peak (a conservative
//! bound: the scene is dropped before the film exists, so the true peak is
//! lower than the sum when both are large). Each part's owner says what it
//! will hold; this module only adds them up:
//! - scene: the bulk arrays of `scene.bin`, held while the render state is built
//!   (motion keys included: deforming meshes', moving points' and
//!   deforming curves' keyed points, normals and widths, moving instances'
//!   keyed transforms), and
//!   the Cryptomatte names kept per instance (8 bytes);
//! - geometry: [`Geometry::bytes_for`] (shading copies, BVHs, the build's
//!   temporaries for the meshes built at once, the top level) and
//!   [`Geometry::keyed_bytes_for`] (keyed triangles, vertices and spheres;
//!   counted whatever the render's shutter, a conservative bound when a
//!   closed shutter leaves the keys unused);
//! - volumes: per density (and emitting temperature or emission) grid,
//!   [`Media::field_bytes_for`] from the VDB grid table (sparse layout,
//!   majorant grid, emission cells; no tree is read), plus what reading the
//!   largest one holds (`GridInfo::read_bytes`);
//! - film: [`Film::bytes_for`] (the sums, once: tiles merge as they finish),
//!   then `output::write_bytes_for` (the output layers and their copies);
//! - runtime: code, libraries and thread stacks, measured once.
//!
//! Subdivision surfaces are checked before they are refined: with the cages
//! loaded (`job::open`), [`check_refinement`] counts what refining them would
//! make ([`Scene::refinement_plan`]: triangles exactly, array bytes bounded),
//! estimates the scene, geometry, volumes and runtime parts as if refined,
//! and refuses, naming the heaviest meshes and the highest level that fits,
//! before any refinement work. The film is checked with the rest once the
//! outputs are planned ([`estimate`], [`check`]).

use std::fmt;
use std::path::{Path, PathBuf};

use glam::UVec2;

use crate::film::{AovSet, Film};
use crate::geometry::Geometry;
use crate::scene::{InstanceNames, PlannedMesh, Refinement, Scene, SceneError};
use crate::volumes::grid::{VdbFile, VolumeError};
use crate::volumes::Media;

/// Bytes in one MiB and one GiB.
const MIB: f64 = (1u64 << 20) as f64;
const GIB: f64 = (1u64 << 30) as f64;

/// Resident bytes of the process before the scene: the binary, OpenVDB,
/// OpenImageIO, TBB and the worker threads' stacks (measured: 131 MiB
/// for `cirrus info`, 134 MiB for an 8x8 render).
const RUNTIME_BYTES: u64 = 144 << 20;

/// A render's estimated peak memory, by part, in bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryEstimate {
    /// The scene's bulk arrays (`scene.bin`), resident while the render state is built.
    pub scene: u64,
    /// Mesh shading copies, per-mesh BVHs and their build, the top-level BVH.
    pub geometry: u64,
    /// Sparse density and emission grids, majorant grids, and the read of the largest.
    pub volumes: u64,
    /// Film sums, then the output layers.
    pub film: u64,
    /// Code, libraries and thread stacks.
    pub runtime: u64,
}

/// Why a render is refused before it starts, or its estimate cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum MemoryError {
    /// The estimate exceeds the limit.
    #[error(
        "the render needs about {needed} ({parts}) but only {limit} is available{source_note}; \
         lower --res, choose fewer --aovs, or raise --memory-limit",
        needed = gib(estimate.total()),
        parts = estimate,
        limit = gib(*limit),
        source_note = if *explicit { " (--memory-limit)" } else { "" }
    )]
    TooLarge {
        /// The estimate refused.
        estimate: MemoryEstimate,
        /// The limit it exceeds, bytes.
        limit: u64,
        /// True when the limit came from `--memory-limit`, false when measured.
        explicit: bool,
    },
    /// Refining the scene's subdivision surfaces would exceed the limit
    /// (checked before refining; the film is not counted yet).
    #[error(
        "refining the subdivision surfaces needs about {needed} ({parts}) but only {limit} is \
         available{source_note}; heaviest: {heaviest}; {fits}",
        needed = gib(estimate.total()),
        parts = estimate,
        limit = gib(*limit),
        source_note = if *explicit { " (--memory-limit)" } else { "" }
    )]
    Refinement {
        /// The estimate refused, film left out.
        estimate: MemoryEstimate,
        /// The limit it exceeds, bytes.
        limit: u64,
        /// True when the limit came from `--memory-limit`, false when measured.
        explicit: bool,
        /// The meshes that would make the most triangles, with their counts and levels.
        heaviest: String,
        /// The level that would fit, and where to set it.
        fits: String,
    },
    /// A volume's grid table cannot be read.
    #[error(transparent)]
    Volume(#[from] VolumeError),
    /// The scene's subdivision surfaces cannot be refined as asked.
    #[error(transparent)]
    Scene(#[from] SceneError),
}

impl MemoryEstimate {
    /// The estimated peak, bytes: the sum of the parts.
    pub fn total(&self) -> u64 {
        self.scene + self.geometry + self.volumes + self.film + self.runtime
    }
}

impl fmt::Display for MemoryEstimate {
    /// `film 2900.0 MiB, volumes 200.0 MiB, ...`: every part, largest first.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = [
            ("film", self.film),
            ("volumes", self.volumes),
            ("geometry", self.geometry),
            ("scene", self.scene),
            ("runtime", self.runtime),
        ];
        parts.sort_by_key(|p| std::cmp::Reverse(p.1));
        let text: Vec<String> = parts
            .iter()
            .map(|(name, bytes)| format!("{name} {:.1} MiB", *bytes as f64 / MIB))
            .collect();
        write!(f, "{}", text.join(", "))
    }
}

/// Refuses `estimate` when its total exceeds `limit` bytes (`--memory-limit`),
/// or, without one, what [`crate::host::available_bytes`] measures; passes when nothing
/// can be measured.
pub fn check(estimate: &MemoryEstimate, limit: Option<u64>) -> Result<(), MemoryError> {
    let Some((limit, explicit)) = limit_of(limit) else {
        return Ok(());
    };
    if estimate.total() > limit {
        return Err(MemoryError::TooLarge {
            estimate: *estimate,
            limit,
            explicit,
        });
    }
    Ok(())
}

/// The limit, bytes, and whether it was given (`--memory-limit`) rather
/// than measured; `None` when nothing can be measured.
fn limit_of(limit: Option<u64>) -> Option<(u64, bool)> {
    match limit {
        Some(l) => Some((l, true)),
        None => crate::host::available_bytes().map(|l| (l, false)),
    }
}

/// Refuses refining the subdivision surfaces of `scene` (loaded as cages,
/// nothing refined) as `refinement` asks when the refined scene's estimate
/// exceeds `limit` bytes (`--memory-limit`; without one, what the machine
/// has), naming its heaviest meshes and the highest level that fits.
pub fn check_refinement(
    scene: &Scene,
    refinement: Refinement,
    limit: Option<u64>,
) -> Result<(), MemoryError> {
    let planned = scene.refinement_plan(refinement, None)?;
    if let (false, Some((limit, explicit))) = (planned.is_empty(), limit_of(limit)) {
        let needs = parts(scene, &planned)?;
        if needs.total() > limit {
            return Err(refusal(scene, refinement, needs, limit, explicit, planned)?);
        }
    }
    Ok(())
}

/// The refusal of refining `planned`: its heaviest meshes, and the highest
/// level (every mesh capped at it) whose estimate fits `limit`.
fn refusal(
    scene: &Scene,
    refinement: Refinement,
    estimate: MemoryEstimate,
    limit: u64,
    explicit: bool,
    mut planned: Vec<PlannedMesh>,
) -> Result<MemoryError, MemoryError> {
    let deepest = planned.iter().map(|p| p.level).max().unwrap_or(0);
    let mut fits = "not even the cages fit (level 0)".to_owned();
    for level in (0..deepest).rev() {
        let capped = scene.refinement_plan(refinement, Some(level))?;
        let needs = parts(scene, &capped)?.total();
        if needs <= limit {
            let authored: Vec<&str> = (capped.iter())
                .filter(|p| p.authored && p.level == level)
                .map(|p| p.path.as_str())
                .collect();
            fits = format!("--subdiv-level {level} would fit (about {})", gib(needs));
            if !authored.is_empty() {
                fits += &format!(
                    ", with primvars:cirrus:subdivisionLevel lowered to {level} on {}",
                    authored.join(", ")
                );
            }
            break;
        }
    }
    planned.sort_by_key(|p| std::cmp::Reverse(p.triangles));
    let heaviest: Vec<String> = (planned.iter().take(3))
        .map(|p| {
            let from = if p.authored { "its own level" } else { "level" };
            format!("{} {} triangles ({from} {})", p.path, p.triangles, p.level)
        })
        .collect();
    Ok(MemoryError::Refinement {
        estimate,
        limit,
        explicit,
        heaviest: heaviest.join(", "),
        fits,
    })
}

/// Estimates the peak memory of rendering `scene` at `resolution` (the
/// render state's, after the stage's settings and `--res`) with `aovs`,
/// reading only the VDB grid tables.
pub fn estimate(
    scene: &Scene,
    resolution: UVec2,
    aovs: &AovSet,
) -> Result<MemoryEstimate, MemoryError> {
    Ok(MemoryEstimate {
        film: film_bytes(resolution, aovs),
        ..parts(scene, &[])?
    })
}

/// Every part but the film, with the meshes of `planned` as refinement
/// would make them (their cages' arrays stay in the scene's blob beside
/// the refined ones, and are counted in both).
fn parts(scene: &Scene, planned: &[PlannedMesh]) -> Result<MemoryEstimate, MemoryError> {
    let arrays = scene.array_bytes();
    let mesh_bytes = planned
        .iter()
        .map(|p| p.bytes)
        .fold(arrays.meshes, u64::saturating_add);
    let keys = Keys::of(scene);
    Ok(MemoryEstimate {
        scene: mesh_bytes
            + arrays.instances
            + keys.array_bytes
            + InstanceNames::bytes_for(scene.manifest.instances.count),
        geometry: geometry_bytes(scene, mesh_bytes, planned) + keys.geometry_bytes,
        volumes: volume_bytes(scene)?,
        film: 0,
        runtime: RUNTIME_BYTES,
    })
}

/// Geometry: the shading copy of every mesh array (as large as the scene's
/// mesh bytes), resident BVHs, the build temporaries of the largest meshes
/// built at once (one per worker thread), and the top level; the meshes of
/// `planned` at their refined triangle counts.
fn geometry_bytes(scene: &Scene, mesh_bytes: u64, planned: &[PlannedMesh]) -> u64 {
    let m = &scene.manifest;
    let mut triangles: Vec<u64> = m.meshes.iter().map(|x| x.triangles.count).collect();
    for p in planned {
        triangles[p.mesh] = p.triangles;
    }
    triangles.sort_unstable_by(|a, b| b.cmp(a));
    let total = triangles.iter().copied().fold(0, u64::saturating_add);
    let building = (triangles.iter().take(rayon::current_num_threads()))
        .copied()
        .fold(0, u64::saturating_add);
    let prototypes = scene.view(&m.instances.prototype);
    let placements: u64 = prototypes
        .iter()
        .map(|&p| {
            let proto = &m.prototypes[p as usize];
            (proto.meshes.len() + proto.points.len() + proto.curves.len()) as u64
        })
        .sum();
    // Points, and curve pieces (a curve of n vertices has n - 1).
    let points = m.points.iter().map(|p| p.points.count);
    let pieces = m
        .curves
        .iter()
        .map(|c| c.points.count - c.vertex_counts.count);
    let mut round: Vec<u64> = points.chain(pieces).collect();
    round.sort_unstable_by(|a, b| b.cmp(a));
    let round_building = round.iter().take(rayon::current_num_threads()).sum();
    let round = [round.iter().sum(), round_building];
    Geometry::bytes_for(mesh_bytes, total, building, placements, round)
}

/// What a scene's motion keys hold, bytes.
struct Keys {
    /// Their `scene.bin` arrays.
    array_bytes: u64,
    /// What geometry builds from them ([`Geometry::keyed_bytes_for`]).
    geometry_bytes: u64,
}

impl Keys {
    /// The keys of `scene`'s deforming meshes, moving points, deforming
    /// curves and moving instances (a deforming subdivision cage counts at
    /// the cage's size).
    fn of(scene: &Scene) -> Self {
        let m = &scene.manifest;
        let bytes = |b: Option<u64>| b.expect("validated array");
        let (mut array_bytes, mut triangle_keys, mut vertex_keys, mut sphere_keys) = (0, 0, 0, 0);
        for mesh in &m.meshes {
            if let Some(motion) = &mesh.motion {
                let keys = motion.times.len() as u64;
                let normals = motion.normals.as_ref();
                array_bytes +=
                    bytes(motion.points.bytes()) + normals.map_or(0, |n| bytes(n.bytes()));
                triangle_keys += keys * mesh.triangles.count;
                vertex_keys += keys * mesh.points.count * if normals.is_some() { 2 } else { 1 };
            }
        }
        // Moving points and deforming curves key one sphere per point or
        // vertex (`round_bvh.rs`).
        let points = m.points.iter().map(|p| (&p.motion, p.points.count));
        let curves = m.curves.iter().map(|c| (&c.motion, c.points.count));
        for (motion, count) in points.chain(curves) {
            if let Some(motion) = motion {
                let widths = motion.widths.as_ref();
                array_bytes +=
                    bytes(motion.points.bytes()) + widths.map_or(0, |w| bytes(w.bytes()));
                sphere_keys += motion.times.len() as u64 * count;
            }
        }
        if let Some(motion) = &m.instances.motion {
            array_bytes += bytes(motion.instance.bytes()) + bytes(motion.transform.bytes());
        }
        Self {
            array_bytes,
            geometry_bytes: Geometry::keyed_bytes_for(triangle_keys, vertex_keys, sphere_keys),
        }
    }
}

/// Volumes: every distinct grid `Media::build` reads (density fields, and
/// temperature or emission fields of emitting volumes) once, from its active
/// voxel count, plus the read temporaries of the largest. Each grid counts a
/// majorant grid's cells over its bounds: a density grid's own, and for an
/// emission grid the copy raised where the volume emits, beside which the
/// emission light keeps [`EMISSION_CELL_BYTES`] per cell.
fn volume_bytes(scene: &Scene) -> Result<u64, VolumeError> {
    // (file, grid, index, emits)
    let mut fields: Vec<(&Path, &str, u32, bool)> = Vec::new();
    for volume in &scene.manifest.volumes {
        for (name, field) in &volume.fields {
            if name == "density" || volume.emits_from(name) {
                fields.push((&field.file, &field.grid, field.index, name != "density"));
            }
        }
    }
    fields.sort();
    fields.dedup();
    let mut files: Vec<(PathBuf, VdbFile)> = Vec::new();
    let (mut resident, mut largest_read) = (0u64, 0u64);
    for (file, grid, index, emits) in fields {
        let vdb = match files.iter().position(|(p, _)| p == file) {
            Some(i) => &files[i].1,
            None => {
                files.push((file.to_path_buf(), VdbFile::open(file)?));
                &files[files.len() - 1].1
            }
        };
        let info = &vdb.grids()[vdb.find(grid, index as usize)?];
        resident += Media::field_bytes_for(info, emits);
        largest_read = largest_read.max(info.read_bytes());
    }
    Ok(resident + largest_read)
}

/// Film: the accumulators (tile films are merged as they finish, so only
/// the few in flight add to them), then what writing the EXRs and the
/// preview holds.
fn film_bytes(resolution: UVec2, aovs: &AovSet) -> u64 {
    let pixels = u64::from(resolution.x) * u64::from(resolution.y);
    Film::bytes_for(pixels, aovs) + crate::output::write_bytes_for(pixels, aovs)
}

/// Parses a byte count for `--memory-limit`: a positive number with an
/// optional binary unit, `K`, `M`, `G` or `T` (powers of 1024), written
/// alone, with `B` or as `KiB`...; case-insensitive: `8G`, `512M`,
/// `1.5GiB`, `1073741824`.
pub fn parse_bytes(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let digits = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(digits);
    let shift = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 0,
        "k" | "kb" | "kib" => 10,
        "m" | "mb" | "mib" => 20,
        "g" | "gb" | "gib" => 30,
        "t" | "tb" | "tib" => 40,
        other => {
            return Err(format!(
                "{s:?}: unknown unit {other:?}; use a number of bytes with K, M, G or T, e.g. 8G"
            ))
        }
    };
    let value: f64 = number
        .parse()
        .map_err(|_| format!("{s:?}: expected a size such as 8G, 512M or 1.5GiB"))?;
    let bytes = value * (1u64 << shift) as f64;
    if !(bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("{s:?}: must be at least one byte and below 16 EiB"));
    }
    Ok(bytes.round() as u64)
}

/// `bytes` for messages: GiB with one decimal, or MiB below 1 GiB.
fn gib(bytes: u64) -> String {
    let b = bytes as f64;
    if b < GIB {
        format!("{:.1} MiB", b / MIB)
    } else {
        format!("{:.1} GiB", b / GIB)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_bytes_reads_binary_units_and_refuses_the_rest() {
        for (text, bytes) in [
            ("1024", 1024),
            ("8G", 8 << 30),
            ("512M", 512 << 20),
            ("512mb", 512 << 20),
            ("1.5GiB", 3 << 29),
            ("64k", 64 << 10),
            ("2T", 2 << 40),
            (" 3 KiB ", 3 << 10),
            ("100B", 100),
        ] {
            assert_eq!(parse_bytes(text), Ok(bytes), "{text}");
        }
        for bad in [
            "",
            "G",
            "0",
            "0.1",
            "-5G",
            "8X",
            "1.2.3G",
            "nanG",
            "inf",
            "99999999T",
        ] {
            assert!(parse_bytes(bad).is_err(), "{bad:?} was accepted");
        }
    }

    fn default_film(width: u32, height: u32, aovs: &str) -> u64 {
        film_bytes(UVec2::new(width, height), &aovs.parse().unwrap())
    }

    #[test]
    fn film_estimate_grows_with_pixels_and_aovs() {
        let beauty = default_film(100, 100, "beauty");
        // The sums (56 B) and the output layers (RGBA three times, 48 B).
        assert_eq!(beauty, 100 * 100 * (56 + 48));
        assert!(default_film(200, 100, "beauty") == 2 * beauty);
        let mut previous = beauty;
        for aovs in ["albedo", "albedo,Z", "default", "all"] {
            let bytes = default_film(100, 100, aovs);
            assert!(bytes > previous, "{aovs}: {bytes} <= {previous}");
            previous = bytes;
        }
        // 65536^2 pixels never wrap around.
        assert!(default_film(65536, 65536, "beauty") > 400 << 30);
    }

    fn estimate_of(film: u64) -> MemoryEstimate {
        MemoryEstimate {
            scene: 1 << 20,
            geometry: 2 << 20,
            volumes: 0,
            film,
            runtime: RUNTIME_BYTES,
        }
    }

    #[test]
    fn check_refuses_above_the_limit_and_names_the_parts() {
        let e = estimate_of(3 << 30);
        assert!(check(&e, Some(e.total())).is_ok());
        let err = check(&e, Some(e.total() - 1)).unwrap_err().to_string();
        assert!(err.contains("needs about 3.1 GiB"), "{err}");
        assert!(
            err.contains("film 3072.0 MiB, runtime 144.0 MiB, geometry 2.0 MiB"),
            "{err}"
        );
        assert!(
            err.contains("(--memory-limit)") && err.contains("lower --res"),
            "{err}"
        );
        // Without a limit, what the machine has: a petabyte is refused here.
        let huge = estimate_of(1 << 50);
        if crate::host::available_bytes().is_some() {
            assert!(check(&huge, None).is_err());
            assert!(check(&estimate_of(1 << 20), None).is_ok());
        }
    }
}
