//! Building [`Media`] from a scene, in the steps `Media::build_at` names:
//! the scene-wide inputs first (checks, velocity fields, moving instances,
//! the blackbody table, the depth scales adaptive majorants split by), then
//! one medium per placed volume part: its density grid and majorant grid,
//! its emission sources, its placement and motion, and, when it emits, its
//! light cells. Grids, majorant grids and light cells are built once and
//! shared by every placement that names them.

use std::collections::HashMap;
use std::sync::Arc;

use glam::{Affine3A, Vec3};

use super::checks::{check_emission_scales, warn_bad_values};
use super::emission::{BlackbodyTable, EmissionCells, SourceSample};
use super::estimators::channel_mean;
use super::fields::{field_key, read_field, read_velocities, FieldKey, Velocity};
use super::grid::{SparseGrid, VolumeError};
use super::majorant::{MajorantGrid, MajorantKind};
use super::medium::{Emission, EmittedRadiance, Media, Medium};
use super::motion::{Advection, PlacementMotion};
use super::phase::HenyeyGreenstein;
use super::placement::{longest_axis, to_f32, to_f64, world_box};
use crate::color::luminance;
use crate::geometry::MovingInstances;
use crate::motion::Shutter;
use crate::scene::{affine, Scene, Volume, VolumeField, VolumePart};

/// An emitting volume's light cells and its majorant grid raised where it
/// emits (see [`Medium::emission_cells`]).
type EmittingGrids = (Option<Arc<EmissionCells>>, Option<Arc<MajorantGrid>>);

impl Media {
    /// [`Self::build_at`] with the shutter closed at the frame: nothing moves.
    pub fn build(scene: &Scene, kind: MajorantKind) -> Result<Self, VolumeError> {
        Self::build_at(scene, kind, Shutter::CLOSED)
    }

    /// Reads every placed volume's density grid (once per file, grid and
    /// index), builds its majorant grid of `kind`, and places it. Under a
    /// `shutter` that is not closed at the frame, volumes with a velocity
    /// field are advected by it and their majorant grids dilated by the
    /// farthest it moves them; otherwise velocity fields are not read.
    pub fn build_at(
        scene: &Scene,
        kind: MajorantKind,
        shutter: Shutter,
    ) -> Result<Self, VolumeError> {
        let volumes = &scene.manifest.volumes;
        warn_without_density(volumes);
        for volume in volumes {
            check_emission_scales(volume)?;
        }
        let mut build = MediaBuild {
            scene,
            kind,
            velocities: read_velocities(scene, shutter)?,
            moving: MovingInstances::new(scene, shutter.blurs()),
            times: (shutter.open, shutter.close),
            blackbody: blackbody_table(volumes),
            depth_scales: depth_scales(scene),
            grids: HashMap::new(),
            emission_grids: HashMap::new(),
            emitters: HashMap::new(),
        };
        let mut media = Vec::new();
        for (instance, part, world_from_volume) in placed_parts(scene) {
            if let Some(medium) = build.medium(instance, part, world_from_volume)? {
                media.push(medium);
            }
        }
        Ok(Self {
            media,
            blackbody: build.blackbody,
        })
    }
}

/// Warns of every Volume without a density field: it is not rendered.
fn warn_without_density(volumes: &[Volume]) {
    for volume in volumes.iter().filter(|v| !v.fields.contains_key("density")) {
        log::warn!(
            "volume {} has no density field; it is not rendered",
            volume.path
        );
    }
}

/// The blackbody table, when some Volume emits from a temperature field.
fn blackbody_table(volumes: &[Volume]) -> Option<BlackbodyTable> {
    volumes
        .iter()
        .any(|v| v.fields.contains_key("temperature") && v.emits_from("temperature"))
        .then(BlackbodyTable::new)
}

/// Every placed volume part, in instance order: its instance, the part, and
/// its world-from-volume map.
fn placed_parts(scene: &Scene) -> impl Iterator<Item = (u32, &VolumePart, Affine3A)> {
    let m = &scene.manifest;
    let prototypes = scene.view(&m.instances.prototype);
    let transforms = scene.view(&m.instances.transform);
    transforms.iter().zip(prototypes).enumerate().flat_map(
        move |(instance, (world_from_prototype, &prototype))| {
            m.prototypes[prototype as usize]
                .volumes
                .iter()
                .map(move |part| {
                    let world_from_volume = affine(world_from_prototype) * affine(&part.transform);
                    (instance as u32, part, world_from_volume)
                })
        },
    )
}

/// Per density grid, its densest placement's sigma_t per unit density x
/// world length per index unit: what adaptive majorants split by.
fn depth_scales(scene: &Scene) -> HashMap<FieldKey, f32> {
    let mut depth_scales: HashMap<FieldKey, f32> = HashMap::new();
    for (_, part, placed) in placed_parts(scene) {
        let volume = &scene.manifest.volumes[part.volume as usize];
        if let Some(field) = volume.fields.get("density") {
            let scale = Vec3::from(volume.density_scale).max_element()
                * longest_axis(to_f64(&placed).matrix3);
            let entry = depth_scales.entry(field_key(field)).or_insert(0.0);
            *entry = entry.max(scale);
        }
    }
    depth_scales
}

/// Reads a Volume's density grid, warning of bad values and of a non-zero
/// background (rendered as 0 outside the stored data).
fn read_density(volume: &Volume, field: &VolumeField) -> Result<SparseGrid, VolumeError> {
    let grid = read_field(field)?;
    warn_bad_values(volume, field, &grid, "densities");
    if grid.background() != 0.0 {
        log::warn!(
            "volume {}: grid {} of {} has background {}; it is rendered as \
             0 outside the grid's stored data",
            volume.path,
            field.grid,
            field.file.display(),
            grid.background()
        );
    }
    Ok(grid)
}

/// The scene-wide inputs of the media, and what their placements share.
struct MediaBuild<'a> {
    scene: &'a Scene,
    kind: MajorantKind,
    /// Per Volume, its velocity field and units per frame, under a shutter
    /// open around the frame.
    velocities: Vec<Option<Velocity>>,
    moving: MovingInstances,
    /// The shutter's open and close, frames relative to the frame.
    times: (f32, f32),
    blackbody: Option<BlackbodyTable>,
    depth_scales: HashMap<FieldKey, f32>,
    /// Density grids and their majorant grids, by field.
    grids: HashMap<FieldKey, (Arc<SparseGrid>, Arc<MajorantGrid>)>,
    /// Emission (temperature or emission) grids, by field.
    emission_grids: HashMap<FieldKey, Arc<SparseGrid>>,
    /// Emission light cells and the majorant grid raised where the volume
    /// emits, per Volume prim: shared by its placements.
    emitters: HashMap<u32, EmittingGrids>,
}

impl MediaBuild<'_> {
    /// The medium of one placed volume part; `None` when its Volume has no
    /// density field (warned once per Volume) or its placement collapses it.
    fn medium(
        &mut self,
        instance: u32,
        part: &VolumePart,
        world_from_volume: Affine3A,
    ) -> Result<Option<Medium>, VolumeError> {
        let scene = self.scene;
        let volume = &scene.manifest.volumes[part.volume as usize];
        let Some(field) = volume.fields.get("density") else {
            return Ok(None); // warned by `warn_without_density`
        };
        let (density, majorant) = self.density_grids(volume, field)?;
        let world_from_index = to_f64(&world_from_volume) * density.transform().world_from_index;
        let index_from_world = world_from_index.inverse();
        if !index_from_world.is_finite() {
            log::warn!(
                "volume {}: its placement collapses it; skipped",
                volume.path
            );
            return Ok(None);
        }
        let emission = self.emission(volume, world_from_volume)?;
        let advection = self.velocities[part.volume as usize]
            .as_ref()
            .map(|(field, per_frame)| {
                Advection::new(Arc::clone(field), density.transform(), *per_frame)
            });
        let motion = self
            .moving
            .mesh_track(instance, affine(&part.transform))
            .map(|track| PlacementMotion::new(&track, &density.transform().world_from_index));
        let (lo, hi) = majorant.index_box();
        let (world_min, world_max) = match &motion {
            Some(motion) => motion.world_box(lo, hi),
            None => world_box(&world_from_index, lo, hi),
        };
        let mut medium = Medium {
            density,
            majorant,
            index_from_world: to_f32(&index_from_world),
            world_min,
            world_max,
            density_scale: Vec3::from(volume.density_scale),
            albedo: Vec3::from(volume.albedo),
            phase: HenyeyGreenstein {
                g: volume.anisotropy,
            },
            emission,
            emitter: None,
            world_from_index: to_f32(&world_from_index),
            voxel_volume: world_from_index.matrix3.determinant().abs() as f32,
            advection,
            motion,
        };
        if !medium.emission.is_empty() {
            self.light_cells(&mut medium, part.volume, volume);
        }
        Ok(Some(medium))
    }

    /// A density grid and its majorant grid of `kind`, read and built the
    /// first time a placement names the field.
    fn density_grids(
        &mut self,
        volume: &Volume,
        field: &VolumeField,
    ) -> Result<(Arc<SparseGrid>, Arc<MajorantGrid>), VolumeError> {
        let key = field_key(field);
        if let Some(found) = self.grids.get(&key) {
            return Ok(found.clone());
        }
        let grid = read_density(volume, field)?;
        let majorant = self.majorant(&grid, &key);
        let entry = (Arc::new(grid), Arc::new(majorant));
        self.grids.insert(key, entry.clone());
        Ok(entry)
    }

    /// The majorant grid of `kind` over the density grid of field `key`,
    /// split by its densest placement's depth scale and dilated by the
    /// farthest any volume advecting it moves it.
    fn majorant(&self, grid: &SparseGrid, key: &FieldKey) -> MajorantGrid {
        let voxel = longest_axis(grid.transform().world_from_index.matrix3);
        let depth = self.depth_scales[key] * voxel;
        let majorant = MajorantGrid::build_for(grid, self.kind, depth);
        let reach = self.advection_reach(grid, key);
        if reach != (Vec3::ZERO, Vec3::ZERO) {
            majorant.dilated(reach)
        } else {
            majorant
        }
    }

    /// Every volume advecting the density grid of field `key`: how far any
    /// moves it over the shutter, the low and high corners of the index-space
    /// box of displacements.
    fn advection_reach(&self, grid: &SparseGrid, key: &FieldKey) -> (Vec3, Vec3) {
        self.scene
            .manifest
            .volumes
            .iter()
            .zip(&self.velocities)
            .filter(|(v, _)| v.fields.get("density").map(field_key).as_ref() == Some(key))
            .filter_map(|(_, velocity)| velocity.as_ref())
            .map(|(field, per_frame)| {
                Advection::reach(field, grid.transform(), *per_frame, self.times)
            })
            .fold((Vec3::ZERO, Vec3::ZERO), |(a, b), (lo, hi)| {
                (a.min(lo), b.max(hi))
            })
    }

    /// The emission sources of a Volume placed by `world_from_volume`: one
    /// per field it emits from, its grid read the first time it is named.
    fn emission(
        &mut self,
        volume: &Volume,
        world_from_volume: Affine3A,
    ) -> Result<Vec<Emission>, VolumeError> {
        let mut emission = Vec::new();
        for (name, field) in &volume.fields {
            let radiance = match name.as_str() {
                _ if !volume.emits_from(name) => continue,
                "temperature" => EmittedRadiance::Blackbody {
                    heat_scale: volume.heat_scale,
                    temperature_offset: volume.temperature_offset,
                    temperature_scale: volume.temperature_scale,
                },
                _ => EmittedRadiance::Scaled(
                    Vec3::from(volume.emission_color) * volume.emission_scale,
                ),
            };
            let key = field_key(field);
            let grid = match self.emission_grids.get(&key) {
                Some(found) => Arc::clone(found),
                None => {
                    let grid = Arc::new(read_field(field)?);
                    warn_bad_values(volume, field, &grid, "values");
                    self.emission_grids.insert(key, Arc::clone(&grid));
                    grid
                }
            };
            let world_from_grid = to_f64(&world_from_volume) * grid.transform().world_from_index;
            emission.push(Emission {
                index_from_world: to_f32(&world_from_grid.inverse()),
                grid,
                radiance,
            });
        }
        Ok(emission)
    }

    /// Gives an emitting medium its light cells and raises its majorant
    /// grid where it emits, built once per Volume prim (`volume_index`);
    /// warns when it also moves by its transform (not light-sampled).
    fn light_cells(&mut self, medium: &mut Medium, volume_index: u32, volume: &Volume) {
        if medium.motion.is_some() {
            log::warn!(
                "volume {}: it emits and moves by its transform over the shutter: its \
                 light is found by tracking alone, not light-sampled (unbiased, noisier)",
                volume.path
            );
        }
        let (cells, raised) = self
            .emitters
            .entry(volume_index)
            .or_insert_with(|| medium.emission_cells(volume, self.blackbody.as_ref(), self.kind))
            .clone();
        medium.emitter = cells;
        if let Some(raised) = raised {
            medium.majorant = raised;
        }
    }
}

impl Medium {
    /// Where this medium emits, for light sampling (`emission/emitter.rs`), and its
    /// majorant grid raised where it emits (`kind` grid only: the global
    /// baseline stays one bound); `None`s when it emits nothing (warned: a
    /// volume that would emit but does not absorb has no source term).
    fn emission_cells(
        &self,
        volume: &Volume,
        blackbody: Option<&BlackbodyTable>,
        kind: MajorantKind,
    ) -> EmittingGrids {
        let absorption = luminance(self.absorption());
        if absorption <= 0.0 {
            log::warn!(
                "volume {}: it has emission fields but its albedo is 1 (sigma_a = 0), so it \
                 emits nothing (the source term is sigma_a Le)",
                volume.path
            );
            return (None, None);
        }
        // The emission grids share the density grid's index points.
        let aligned = self.emission.iter().all(|e| {
            let map = e.index_from_world * self.world_from_index;
            map.abs_diff_eq(Affine3A::IDENTITY, 1e-4)
        });
        let source = |p_index: Vec3| {
            let p = self.world_from_index.transform_point3(p_index);
            let le = self.emitted(p, blackbody);
            let density = self.density(p_index);
            SourceSample {
                sigma_t: channel_mean(self.density_scale) * density,
                source: luminance(self.absorption() * density * le),
                radiance: luminance(le),
            }
        };
        let m = &self.world_from_index.matrix3;
        let axis_length = Vec3::new(m.x_axis.length(), m.y_axis.length(), m.z_axis.length());
        let cells =
            EmissionCells::build(&self.majorant, (absorption, axis_length), aligned, source);
        let Some(cells) = cells else {
            log::warn!(
                "volume {}: its emission fields emit nothing where it has density; \
                 no emission is rendered",
                volume.path
            );
            return (None, None);
        };
        let raised = (kind != MajorantKind::Global).then(|| {
            let per_density = 1.0 / self.density_scale.max_element();
            let floors = cells.collision_floors().iter();
            Arc::new(
                self.majorant
                    .with_floors(floors.map(|&(slot, sigma)| (slot, sigma * per_density))),
            )
        });
        (Some(Arc::new(cells)), raised)
    }
}
