//! The scene's volumes as participating media, in world space: each placed
//! Volume (instance x prototype volume part) is a density grid seen through
//! its world-from-index map, with its majorant grid and its shading
//! (docs/conventions.md, "Volumes"). Grids and majorant grids are read once
//! per (file, grid name, index) and shared by every placement, so instanced
//! volumes cost one grid.
//!
//! Extinction is RGB: sigma_t = densityScale x density per world unit, with
//! a grey or per-channel densityScale (chromatic extinction); albedo is RGB
//! (sigma_s = albedo x sigma_t, sigma_a = sigma_t - sigma_s);
//! a temperature field with a positive `heatScale` emits blackbody radiance
//! (`emission/blackbody.rs`), an emission field emits emissionScale x emissionColor x
//! its value; the source term is sigma_a x Le either way (pbrt-v4's grid
//! medium does the same). Overlapping media add their
//! extinctions: along a ray, their majorant segments are merged and summed.

use std::f32::consts::PI;
use std::sync::Arc;

use glam::{Affine3A, Vec3};
use smallvec::SmallVec;

use super::emission::{BlackbodyTable, EmissionCells, NearImportance};
use super::grid::{GridInfo, SparseGrid};
use super::majorant::{MajorantGrid, MajorantSegments};
use super::motion::{Advection, PlacementMotion};
use super::overlap::{box_hit, merge};
use super::phase::HenyeyGreenstein;
use super::placement::{to_f64, world_box};
use super::segment::MajorantSegment;

/// One placed volume.
pub struct Medium {
    pub(super) density: Arc<SparseGrid>,
    pub(super) majorant: Arc<MajorantGrid>,
    /// World (scene units) to the grid's index space, the placement included.
    pub(super) index_from_world: Affine3A,
    /// World-space box of the grid's stored data, for quick ray rejection.
    pub(super) world_min: Vec3,
    pub(super) world_max: Vec3,
    /// `densityScale`: sigma_t per world unit per unit density, per RGB channel.
    pub(super) density_scale: Vec3,
    /// sigma_s / sigma_t per RGB channel.
    pub(super) albedo: Vec3,
    /// Henyey-Greenstein phase function (`anisotropy`).
    pub(super) phase: HenyeyGreenstein,
    /// Emission sources (temperature and/or emission fields); empty, and
    /// free, for volumes that do not emit.
    pub(super) emission: Vec<Emission>,
    /// Where it emits, for light sampling; `None` when it emits nothing.
    pub(super) emitter: Option<Arc<EmissionCells>>,
    /// Index (voxel) space to world, the inverse of `index_from_world`.
    pub(super) world_from_index: Affine3A,
    /// World volume of one index-space unit cube, |det(world_from_index)|.
    pub(super) voxel_volume: f32,
    /// Its velocity field, when it has one and the shutter is not closed
    /// at the frame (`motion/advection.rs`); `None` reads every grid where it is.
    pub(super) advection: Option<Advection>,
    /// Its placement over the shutter when its transform moves
    /// (`motion/moving.rs`): rays enter index space at their time, and the frame
    /// maps above (`index_from_world`, the emission grids') serve the
    /// index-space points they reach. `None` for a still placement.
    pub(super) motion: Option<PlacementMotion>,
}

impl Medium {
    /// Density at index-space point `p`: trilinear, with negative values
    /// read as 0 and non-finite ones (and their trilinear neighbourhood) as
    /// 0 too, so bad voxels can neither make extinction negative nor stall
    /// tracking with an infinite majorant; `Media::build` reports them.
    #[inline]
    pub(super) fn density(&self, p: Vec3) -> f32 {
        let v = self.density.trilinear_index(p);
        if v.is_finite() {
            v.max(0.0)
        } else {
            0.0
        }
    }

    /// Density at index-space point `p` at `time` (frames): read where its
    /// velocity field brings it from (the point itself without one).
    #[inline]
    fn density_at(&self, p: Vec3, time: f32) -> f32 {
        match &self.advection {
            Some(advection) => self.density(p - advection.displacement(p, time)),
            None => self.density(p),
        }
    }

    /// The source term sigma_a Le at world point `p` and `time` (frames),
    /// W/(m^3 sr) in scene units, per RGB channel (zero for media that do
    /// not emit).
    fn source(&self, p: Vec3, time: f32, blackbody: Option<&BlackbodyTable>) -> Vec3 {
        if self.emission.is_empty() {
            return Vec3::ZERO;
        }
        let p_index = self.index_from_world_at(time).transform_point3(p);
        // A moving placement's emission grids are read where the point sits
        // at the frame.
        let p = match &self.motion {
            Some(_) => self.world_from_index.transform_point3(p_index),
            None => p,
        };
        let (p_index, p) = match &self.advection {
            Some(advection) => {
                let back = advection.displacement(p_index, time);
                (
                    p_index - back,
                    p - self.world_from_index.transform_vector3(back),
                )
            }
            None => (p_index, p),
        };
        let sigma_a = self.absorption() * self.density(p_index);
        if sigma_a == Vec3::ZERO {
            return Vec3::ZERO;
        }
        sigma_a * self.emitted(p, blackbody)
    }

    /// World to index space at `time` (frames): the frame's map for a
    /// still placement.
    #[inline]
    fn index_from_world_at(&self, time: f32) -> Affine3A {
        match &self.motion {
            Some(motion) => motion.index_from_world(time),
            None => self.index_from_world,
        }
    }

    /// The emitted radiance Le at world point `p`, W/(m^2 sr) per RGB
    /// channel: the sum over its emission sources.
    pub(super) fn emitted(&self, p: Vec3, blackbody: Option<&BlackbodyTable>) -> Vec3 {
        self.emission.iter().map(|e| e.radiance(p, blackbody)).sum()
    }

    /// sigma_a per world unit per unit density, per RGB channel:
    /// (1 - albedo) x densityScale.
    pub(super) fn absorption(&self) -> Vec3 {
        (Vec3::ONE - self.albedo).max(Vec3::ZERO) * self.density_scale
    }
}

/// One emission source of a medium: a grid and how its values become
/// radiance.
pub(super) struct Emission {
    pub(super) grid: Arc<SparseGrid>,
    /// World to the grid's index space (its own transform).
    pub(super) index_from_world: Affine3A,
    pub(super) radiance: EmittedRadiance,
}

/// How an emission grid's value becomes emitted radiance Le, W/(m^2 sr).
pub(super) enum EmittedRadiance {
    /// A temperature field: Le = heatScale x blackbody(T) normalised to
    /// luminance 1 at 1500 K, T = temperatureOffset + temperatureScale x
    /// value, kelvin.
    Blackbody {
        heat_scale: f32,
        temperature_offset: f32,
        temperature_scale: f32,
    },
    /// An emission field: Le = emissionScale x emissionColor x value
    /// (negative and non-finite values read as 0).
    Scaled(Vec3),
}

impl Emission {
    /// Le at world point `p`, W/(m^2 sr); `blackbody` is present whenever
    /// a medium has a temperature source.
    #[inline]
    fn radiance(&self, p: Vec3, blackbody: Option<&BlackbodyTable>) -> Vec3 {
        let value = self
            .grid
            .trilinear_index(self.index_from_world.transform_point3(p));
        // Non-finite and negative values read as 0, as densities do.
        let value = if value.is_finite() {
            value.max(0.0)
        } else {
            0.0
        };
        match (&self.radiance, blackbody) {
            (
                EmittedRadiance::Blackbody {
                    heat_scale,
                    temperature_offset,
                    temperature_scale,
                },
                Some(table),
            ) => table.radiance(temperature_offset + temperature_scale * value) * *heat_scale,
            (EmittedRadiance::Scaled(scale), _) => *scale * value,
            _ => Vec3::ZERO,
        }
    }
}

/// Every medium of a scene; empty (and free) for scenes without volumes.
#[derive(Default)]
pub struct Media {
    pub(super) media: Vec<Medium>,
    /// Blackbody radiance by temperature, built only when a medium emits.
    pub(super) blackbody: Option<BlackbodyTable>,
}

/// A ray prepared against the media it crosses: each medium's index-space
/// ray, so density lookups along it are one multiply-add.
pub struct MediaRay<'a> {
    /// Held inline for up to two media: most rays cross one, and a heap
    /// allocation per ray showed in profiles.
    media: SmallVec<[(&'a Medium, Vec3, Vec3); 2]>,
    blackbody: Option<&'a BlackbodyTable>,
    origin: Vec3,
    direction: Vec3,
    /// The ray's time, frames relative to the frame.
    time: f32,
}

/// The majorant segments of a [`MediaRay`], front to back: one medium's DDA
/// walked lazily, or a list (the merged segments of overlapping media, or
/// segments a caller collected to look at them twice).
pub enum RaySegments<'a> {
    /// The cells of the only medium the ray crosses.
    Single(MajorantSegments<'a>),
    /// Segments already listed.
    Listed(std::vec::IntoIter<MajorantSegment>),
}

impl Iterator for RaySegments<'_> {
    type Item = MajorantSegment;

    #[inline]
    fn next(&mut self) -> Option<MajorantSegment> {
        match self {
            Self::Single(cells) => cells.next(),
            Self::Listed(listed) => listed.next(),
        }
    }
}

/// The media's coefficients at one point, where a tentative collision
/// looked them up (per world unit).
#[derive(Clone, Copy, Debug)]
pub struct MediumPoint {
    /// Extinction sigma_t per RGB channel, summed over the overlapping media.
    pub sigma_t: Vec3,
    /// Scattering sigma_s = albedo x sigma_t per RGB channel, summed.
    pub sigma_s: Vec3,
    /// Emission sigma_a Le, W/(m^3 sr) in scene units (radiance added per
    /// unit length): the source term of the RTE, summed over media.
    pub emission: Vec3,
}

/// A medium that emits, as the lights see it.
#[derive(Clone, Debug)]
pub struct Emitter {
    /// Which medium ([`Media::sample_emission`] takes it).
    pub medium: usize,
    /// World box around every point that may emit.
    pub world_min: Vec3,
    /// Its max corner.
    pub world_max: Vec3,
    /// Luminance of the power that leaves the volume, W: 4 pi (gas emits the
    /// same in every direction) x the integral of sigma_a Le times an
    /// estimate of its escape transmittance (`emission/emitter.rs`).
    pub power: f32,
    /// What it delivers near its emission, by region (`emission/near_picks.rs`).
    pub(crate) near: NearImportance,
}

impl Media {
    /// The media that emit and do not move by their transforms (those are
    /// not light-sampled: a light sample would sit where they are at the
    /// frame), with what the light selection needs of them.
    pub fn emitters(&self) -> impl Iterator<Item = Emitter> + '_ {
        let still = self.media.iter().map(|m| m.motion.is_none());
        self.media
            .iter()
            .zip(still)
            .enumerate()
            .filter_map(|(i, (m, still))| {
                let cells = m.emitter.as_ref().filter(|_| still)?;
                let (lo, hi) = cells.index_box();
                let (world_min, world_max) = world_box(&to_f64(&m.world_from_index), lo, hi);
                Some(Emitter {
                    medium: i,
                    world_min,
                    world_max,
                    power: 4.0 * PI * cells.escaping() * m.voxel_volume,
                    near: cells.near_importance(m.index_from_world, m.voxel_volume),
                })
            })
    }

    /// A world point of `medium`'s emission picked for world shading point
    /// `from` (by power, or near the emission by what it delivers there)
    /// with `u` in [0, 1)^3, and the density of that pick per cubic scene
    /// unit; `None` for a medium that does not emit.
    pub fn sample_emission(&self, medium: usize, from: Vec3, u: Vec3) -> Option<(Vec3, f32)> {
        let m = &self.media[medium];
        let from = m.index_from_world.transform_point3(from);
        let (p_index, pdf_index) = m.emitter.as_ref()?.sample(from, u);
        Some((
            m.world_from_index.transform_point3(p_index),
            pdf_index / m.voxel_volume,
        ))
    }

    /// The density per cubic scene unit with which [`Self::sample_emission`]
    /// for world shading point `from` picks world point `p` of `medium`.
    pub fn emission_pdf(&self, medium: usize, from: Vec3, p: Vec3) -> f32 {
        let m = &self.media[medium];
        m.emitter.as_ref().map_or(0.0, |cells| {
            let to_index = |p| m.index_from_world.transform_point3(p);
            cells.pdf(&m.majorant, to_index(from), to_index(p)) / m.voxel_volume
        })
    }

    /// The source term sigma_a Le at world point `p` and `time` (frames),
    /// W/(m^3 sr) in scene units per RGB channel, summed over the media.
    pub fn source(&self, p: Vec3, time: f32) -> Vec3 {
        self.media
            .iter()
            .map(|m| m.source(p, time, self.blackbody.as_ref()))
            .sum()
    }

    /// The majorant tracking uses at world point `p` and `time` (frames),
    /// per world unit: the sum over media of their cells' (what
    /// [`MediaRay::segments`] carries there), the rate of tentative
    /// collisions around `p`.
    pub fn sigma_maj_at(&self, p: Vec3, time: f32) -> f32 {
        self.media
            .iter()
            .map(|m| {
                let p_index = m.index_from_world_at(time).transform_point3(p);
                m.majorant.max_at(p_index) * m.density_scale.max_element()
            })
            .sum()
    }

    /// True when some medium emits, light-sampled or not (one moving by its
    /// transform is found by tracking alone, see [`Self::emitters`]).
    pub fn emits(&self) -> bool {
        self.media.iter().any(|m| m.emitter.is_some())
    }

    /// True when the scene has no volume: the integrator skips all media work.
    pub fn is_empty(&self) -> bool {
        self.media.is_empty()
    }

    /// Bytes a medium keeps for the grid `info` describes, estimated from
    /// the grid table before it is read (the memory preflight): its sparse
    /// layout and majorant grid, and, for an emission (or temperature) grid
    /// that `emits`, the emission cells light sampling picks from.
    pub fn field_bytes_for(info: &GridInfo, emits: bool) -> u64 {
        let dims = info.dims();
        let emission = if emits {
            EmissionCells::bytes_for(MajorantGrid::cells_for(dims), info.active_voxel_count)
        } else {
            0
        };
        SparseGrid::bytes_for(dims, info.leaves()) + MajorantGrid::bytes_for(dims) + emission
    }

    /// Bytes held by the grids, majorant grids and emission cells of every
    /// medium, each shared one (instances) counted once.
    pub fn memory_bytes(&self) -> u64 {
        let mut seen = std::collections::HashSet::new();
        let mut bytes = 0;
        let mut count = |ptr: *const u8, size: usize| {
            if seen.insert(ptr) {
                bytes += size as u64;
            }
        };
        for m in &self.media {
            count(Arc::as_ptr(&m.density).cast(), m.density.memory_bytes());
            count(Arc::as_ptr(&m.majorant).cast(), m.majorant.memory_bytes());
            if let Some(a) = &m.advection {
                count(Arc::as_ptr(a.field()).cast(), a.field().memory_bytes());
            }
            for e in &m.emission {
                count(Arc::as_ptr(&e.grid).cast(), e.grid.memory_bytes());
            }
            if let Some(cells) = &m.emitter {
                count(Arc::as_ptr(cells).cast(), cells.memory_bytes());
            }
        }
        bytes
    }

    /// The media crossed by `origin + t direction` (unit `direction`, world
    /// units) for t in `[0, t_max)`, at `time` (frames relative to the frame).
    pub fn along(&self, origin: Vec3, direction: Vec3, t_max: f32, time: f32) -> MediaRay<'_> {
        let media = self
            .media
            .iter()
            .filter(|m| box_hit(origin, direction, t_max, m.world_min, m.world_max))
            .filter_map(|m| {
                let (o, d) = match &m.motion {
                    Some(motion) => motion.index_ray(origin, direction, time)?,
                    None => (
                        m.index_from_world.transform_point3(origin),
                        m.index_from_world.transform_vector3(direction),
                    ),
                };
                Some((m, o, d))
            })
            .collect();
        MediaRay {
            media,
            blackbody: self.blackbody.as_ref(),
            origin,
            direction,
            time,
        }
    }
}

impl<'a> MediaRay<'a> {
    /// True when the ray crosses no medium.
    pub fn is_empty(&self) -> bool {
        self.media.is_empty()
    }

    /// The majorant segments over `[t_min, t_max)`, front to back: with one
    /// medium its own, walked lazily by the DDA (a free flight that ends
    /// early never visits the cells beyond); with several, the union of
    /// their boundaries, each piece carrying the sum of the majorants (and
    /// minorants) covering it.
    pub fn segments(&self, t_min: f32, t_max: f32) -> RaySegments<'a> {
        let per_medium = |(m, o, d): &(&'a Medium, Vec3, Vec3)| {
            m.majorant.segments(*o, *d, t_min, t_max, m.density_scale)
        };
        match self.media.as_slice() {
            [] => RaySegments::Listed(Vec::new().into_iter()),
            [one] => RaySegments::Single(per_medium(one)),
            several => RaySegments::Listed(
                merge(several.iter().map(|m| per_medium(m).collect()).collect()).into_iter(),
            ),
        }
    }

    /// Extinction at ray parameter `t`, per world unit and RGB channel: the
    /// sum over media.
    pub fn sigma_t(&self, t: f32) -> Vec3 {
        self.media
            .iter()
            .map(|(m, o, d)| m.density_scale * m.density_at(*o + *d * t, self.time))
            .sum()
    }

    /// Extinction, scattering and emission at `t`. Temperature grids are
    /// read only for media that emit.
    pub fn at(&self, t: f32) -> MediumPoint {
        let mut point = MediumPoint {
            sigma_t: Vec3::ZERO,
            sigma_s: Vec3::ZERO,
            emission: Vec3::ZERO,
        };
        for (m, o, d) in &self.media {
            let p_index = *o + *d * t;
            let back = m
                .advection
                .as_ref()
                .map(|a| a.displacement(p_index, self.time));
            let sigma = m.density_scale * m.density(p_index - back.unwrap_or(Vec3::ZERO));
            point.sigma_t += sigma;
            point.sigma_s += m.albedo * sigma;
            if !m.emission.is_empty() {
                let mut p = self.origin + self.direction * t;
                if m.motion.is_some() {
                    // Where the point sits at the frame, which the emission grids see.
                    p = m.world_from_index.transform_point3(p_index);
                }
                if let Some(back) = back {
                    p -= m.world_from_index.transform_vector3(back);
                }
                let sigma_a = (Vec3::ONE - m.albedo).max(Vec3::ZERO) * sigma;
                point.emission += sigma_a * m.emitted(p, self.blackbody);
            }
        }
        point
    }

    /// The phase function at a real scattering event at `t`: with one
    /// medium its own; where media overlap, medium i is chosen with
    /// probability proportional to its mean sigma_s there (`u` uniform in
    /// [0, 1)), which samples their sigma_s-weighted mixture exactly.
    pub fn phase(&self, t: f32, u: f32) -> HenyeyGreenstein {
        if let [(m, _, _)] = self.media.as_slice() {
            return m.phase;
        }
        let weight = |(m, o, d): &(&Medium, Vec3, Vec3)| {
            (m.albedo * m.density_scale).element_sum() * m.density_at(*o + *d * t, self.time)
        };
        let mut pick = u * self.media.iter().map(weight).sum::<f32>();
        for medium in &self.media {
            pick -= weight(medium);
            if pick < 0.0 {
                return medium.0.phase;
            }
        }
        self.media
            .last()
            .map_or(HenyeyGreenstein { g: 0.0 }, |(m, _, _)| m.phase)
    }
}
