//! Arbitrary output variables (AOVs): the image layers written beside the
//! beauty for compositing, what one path sample contributes to each, and
//! their channel names as Nuke expects them (`diffuse_direct.R`, `N.X`, `Z`,
//! `CryptoObject00.R`).
//!
//! Light-path AOVs split the beauty by the path's first scattering event
//! after the camera (light path expressions, `C` camera, `R` reflection, `T`
//! transmission, `V` volume, `D` diffuse, `G`/`S` glossy or specular, `L`
//! light or emitter, `O` object emission): `emission` = `C[LO]`,
//! `diffuse_direct` = `C<RD>[LO]`, `diffuse_indirect` = `C<RD>.+[LO]`,
//! `specular_direct`/`_indirect` = the same with `<R[GS]>`, `transmission` =
//! `C<T.>.*[LO]`, `volume_direct`/`_indirect` = `C<V.>[LO]` / `C<V.>.+[LO]`.
//! Every contribution goes to exactly one of them, so they sum to the
//! beauty.

use std::borrow::Cow;
use std::fmt;
use std::str::FromStr;

use glam::Vec3;

use crate::image::PixelType;

/// One AOV.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Aov {
    /// Light reaching the camera without scattering: visible lights and
    /// emitters, the dome, volume emission along camera rays.
    Emission,
    /// Light after one diffuse reflection at the first hit.
    DiffuseDirect,
    /// Light after a diffuse first reflection and more events.
    DiffuseIndirect,
    /// Light after one glossy or specular reflection at the first hit.
    SpecularDirect,
    /// Light after a glossy first reflection and more events.
    SpecularIndirect,
    /// Light transmitted (refracted or straight through) at the first hit.
    Transmission,
    /// Light after one real scattering event in a volume.
    VolumeDirect,
    /// Light after a volume first scattering event and more events.
    VolumeIndirect,
    /// Reflectance of the first non-Dirac event (a denoiser input).
    Albedo,
    /// World-space shading normal of the camera ray's surface hit, averaged.
    N,
    /// World position of the camera ray's surface hit, averaged, scene units.
    P,
    /// Camera-space depth of the camera ray's surface hit: the minimum over
    /// the pixel's samples (a depth is not averaged), +inf where none.
    Z,
    /// Samples per pixel.
    SampleCount,
    /// Variance of the pixel's mean beauty: sample variance / n, per channel.
    Variance,
    /// Cryptomatte of the objects the camera rays hit: each instance's own
    /// prim paths (docs/conventions.md, "Cryptomatte names").
    CryptoObject,
    /// Cryptomatte of the bound Material prims the camera rays hit.
    CryptoMaterial,
    /// Cryptomatte of the assets the camera rays hit: the nearest
    /// `component` or `assembly` model above each object.
    CryptoAsset,
    /// A primvar of the camera ray's surface hit, averaged (a `primvars:*`
    /// RenderVar; 0 where the hit surface lacks it or nothing is hit):
    /// `name` is the MurmurHash3 (seed 0) of the primvar's name, `width` the
    /// channels written (1 to 3). Never in `all` or `default`.
    Primvar {
        /// MurmurHash3 of the primvar name (`displayColor`, no `primvars:`).
        name: u32,
        /// Channels: 1 (the primvar's first component), 2 or 3.
        width: u8,
    },
}

/// Most primvar AOVs one render accumulates ([`AovSample::primvars`]).
pub const MAX_PRIMVARS: usize = 8;

/// Every AOV, in file order.
pub const ALL: [Aov; 17] = [
    Aov::Emission,
    Aov::DiffuseDirect,
    Aov::DiffuseIndirect,
    Aov::SpecularDirect,
    Aov::SpecularIndirect,
    Aov::Transmission,
    Aov::VolumeDirect,
    Aov::VolumeIndirect,
    Aov::Albedo,
    Aov::N,
    Aov::P,
    Aov::Z,
    Aov::SampleCount,
    Aov::Variance,
    Aov::CryptoObject,
    Aov::CryptoMaterial,
    Aov::CryptoAsset,
];

/// The Cryptomatte AOVs, in file order.
pub const CRYPTOMATTES: [Aov; 3] = [Aov::CryptoObject, Aov::CryptoMaterial, Aov::CryptoAsset];

/// What one camera path sample gives every AOV; the film keeps those asked for.
#[derive(Clone, Copy, Debug)]
pub struct AovSample {
    /// Radiance per light-path AOV (the first eight of [`ALL`]), W/(m^2 sr);
    /// their sum is the sample's beauty.
    pub light_paths: [Vec3; 8],
    /// Reflectance of the first non-Dirac event (0 when there is none).
    pub albedo: Vec3,
    /// The camera ray's surface hit, if any.
    pub hit: Option<CameraHit>,
    /// The camera ray hit a surface or collided in a volume (beauty alpha).
    pub opaque: bool,
    /// The hit surface's value of each primvar AOV, in the set's order
    /// ([`AovSet::primvars`]); 0 without a hit or without that primvar.
    pub primvars: [Vec3; MAX_PRIMVARS],
}

/// Where a camera ray met the first surface.
#[derive(Clone, Copy, Debug)]
pub struct CameraHit {
    /// World shading normal.
    pub normal: Vec3,
    /// World position, scene units.
    pub position: Vec3,
    /// Camera-space depth, scene units.
    pub depth: f32,
    /// Its Cryptomatte ids.
    pub ids: CryptoIds,
}

/// The Cryptomatte ids of a surface hit: the MurmurHash3 (seed 0) of the
/// names it has in each Cryptomatte (before `uint32_to_float32`); 0 (and
/// `None` for the material) in a Cryptomatte the render does not write,
/// which is never hashed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CryptoIds {
    /// Of its object name (CryptoObject).
    pub object: u32,
    /// Of its bound material's path (CryptoMaterial); `None` when unbound.
    pub material: Option<u32>,
    /// Of its asset name (CryptoAsset).
    pub asset: u32,
}

impl CryptoIds {
    /// The id in Cryptomatte `aov`; `None` for an unbound material or an AOV
    /// that is no Cryptomatte.
    pub fn of(&self, aov: Aov) -> Option<u32> {
        match aov {
            Aov::CryptoObject => Some(self.object),
            Aov::CryptoMaterial => self.material,
            Aov::CryptoAsset => Some(self.asset),
            _ => None,
        }
    }
}

impl Default for AovSample {
    fn default() -> Self {
        Self {
            light_paths: [Vec3::ZERO; 8],
            albedo: Vec3::ZERO,
            hit: None,
            opaque: false,
            primvars: [Vec3::ZERO; MAX_PRIMVARS],
        }
    }
}

impl AovSample {
    /// Adds `contribution`, which reached the camera after `events`
    /// scattering events, to its light-path AOV: 0 events is emission; after
    /// that the first event's kind decides, and `first` gives the share of
    /// the contribution each kind takes, in the order diffuse, specular,
    /// transmission, volume (per RGB channel, summing to 1 where the
    /// contribution is non-zero).
    pub fn add(&mut self, contribution: Vec3, events: u32, first: &[Vec3; 4]) {
        if events == 0 {
            self.light_paths[0] += contribution;
            return;
        }
        let direct = events == 1;
        for (kind, share) in first.iter().enumerate() {
            if *share == Vec3::ZERO {
                continue;
            }
            let index = match (kind, direct) {
                (0, true) => 1,
                (0, false) => 2,
                (1, true) => 3,
                (1, false) => 4,
                (2, _) => 5,
                (_, true) => 6,
                (_, false) => 7,
            };
            self.light_paths[index] += contribution * *share;
        }
    }

    /// Scales the light-path AOVs per channel, as a clamp scales the beauty.
    pub fn scale(&mut self, factor: Vec3) {
        for v in &mut self.light_paths {
            *v *= factor;
        }
    }
}

impl Aov {
    /// The layer name: channels are `<name>.R` etc. (`Z`, `sample_count`
    /// and a one-channel primvar are single channels of that name). A
    /// primvar's is `primvar_<name hash in hex>_<width>`, unique in a film.
    pub fn name(self) -> Cow<'static, str> {
        Cow::Borrowed(match self {
            Aov::Emission => "emission",
            Aov::DiffuseDirect => "diffuse_direct",
            Aov::DiffuseIndirect => "diffuse_indirect",
            Aov::SpecularDirect => "specular_direct",
            Aov::SpecularIndirect => "specular_indirect",
            Aov::Transmission => "transmission",
            Aov::VolumeDirect => "volume_direct",
            Aov::VolumeIndirect => "volume_indirect",
            Aov::Albedo => "albedo",
            Aov::N => "N",
            Aov::P => "P",
            Aov::Z => "Z",
            Aov::SampleCount => "sample_count",
            Aov::Variance => "variance",
            Aov::CryptoObject => "CryptoObject",
            Aov::CryptoMaterial => "CryptoMaterial",
            Aov::CryptoAsset => "CryptoAsset",
            Aov::Primvar { name, width } => {
                return Cow::Owned(format!("primvar_{name:08x}_{width}"))
            }
        })
    }

    /// Channel names in file order.
    pub fn channels(self) -> Vec<String> {
        let with = |suffixes: [&str; 3]| {
            suffixes
                .iter()
                .map(|s| format!("{}.{s}", self.name()))
                .collect()
        };
        match self {
            Aov::N | Aov::P => with(["X", "Y", "Z"]),
            Aov::Z | Aov::SampleCount | Aov::Primvar { width: 1, .. } => {
                vec![self.name().into_owned()]
            }
            Aov::CryptoObject | Aov::CryptoMaterial | Aov::CryptoAsset => {
                super::cryptomatte::channel_names(&self.name())
            }
            Aov::Primvar { width, .. } => with(["R", "G", "B"])
                .into_iter()
                .take(usize::from(width))
                .collect(),
            _ => with(["R", "G", "B"]),
        }
    }

    /// In `--aovs default`: all but P, sample_count and variance (the light
    /// paths, the denoiser inputs and the three Cryptomattes).
    fn in_default_set(self) -> bool {
        !matches!(self, Aov::P | Aov::SampleCount | Aov::Variance)
    }

    /// Storage: half for colours, float for geometry, counts, variance and IDs.
    pub fn pixel_type(self) -> PixelType {
        match self {
            Aov::N
            | Aov::P
            | Aov::Z
            | Aov::SampleCount
            | Aov::Variance
            | Aov::CryptoObject
            | Aov::CryptoMaterial
            | Aov::CryptoAsset
            | Aov::Primvar { .. } => PixelType::Float,
            _ => PixelType::Half,
        }
    }

    /// The AOV `text` names ([`Self::name`]).
    fn from_set_name(text: &str) -> Option<Self> {
        if let Some(rest) = text.strip_prefix("primvar_") {
            let (name, width) = rest.split_once('_')?;
            let width: u8 = width.parse().ok().filter(|w| (1..=3).contains(w))?;
            let name = u32::from_str_radix(name, 16).ok()?;
            return Some(Aov::Primvar { name, width });
        }
        ALL.into_iter().find(|a| a.name() == text)
    }
}

/// The primvar a `RenderVar` reads, as husk and Karma take them: its
/// `sourceName` without `primvars:` when `sourceType` is `primvar` or the
/// name starts with `primvars:`; `None` for other vars.
pub fn primvar_of<'a>(source_name: &'a str, source_type: &str) -> Option<&'a str> {
    let name = source_name.trim();
    match name.strip_prefix("primvars:") {
        Some(primvar) => Some(primvar),
        None => (source_type == "primvar").then_some(name),
    }
}

/// The AOVs a render writes (`--aovs default|all|beauty|name,name,...`),
/// sorted in file order without repeats.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AovSet(Vec<Aov>);

impl AovSet {
    /// No AOVs: the beauty alone (`--aovs beauty`; what benchmarks measure).
    pub fn beauty_only() -> Self {
        Self(Vec::new())
    }

    /// The chosen AOVs, in file order.
    pub fn aovs(&self) -> &[Aov] {
        &self.0
    }

    /// Whether `aov` is chosen.
    pub fn contains(&self, aov: Aov) -> bool {
        self.0.contains(&aov)
    }

    /// The chosen primvar AOVs' name hashes, in set order: the order of
    /// [`AovSample::primvars`].
    pub fn primvars(&self) -> impl Iterator<Item = u32> + '_ {
        self.0.iter().filter_map(|a| match a {
            Aov::Primvar { name, .. } => Some(*name),
            _ => None,
        })
    }

    /// The index of primvar AOV `aov` in [`AovSample::primvars`]; `None`
    /// for other AOVs and beyond [`MAX_PRIMVARS`].
    pub fn primvar_slot(&self, aov: Aov) -> Option<usize> {
        let Aov::Primvar { name, .. } = aov else {
            return None;
        };
        self.primvars()
            .position(|n| n == name)
            .filter(|&i| i < MAX_PRIMVARS)
    }
}

impl FromIterator<Aov> for AovSet {
    /// The set of these AOVs, sorted, without repeats.
    fn from_iter<I: IntoIterator<Item = Aov>>(aovs: I) -> Self {
        let mut aovs: Vec<Aov> = aovs.into_iter().collect();
        aovs.sort();
        aovs.dedup();
        Self(aovs)
    }
}

impl Default for AovSet {
    fn default() -> Self {
        Self(ALL.into_iter().filter(|a| a.in_default_set()).collect())
    }
}

impl FromStr for AovSet {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let mut aovs = match s {
            "default" => return Ok(Self::default()),
            "all" => ALL.to_vec(),
            "beauty" => return Ok(Self::beauty_only()),
            list => list
                .split(',')
                .map(|name| {
                    let name = name.trim();
                    Aov::from_set_name(name).ok_or_else(|| {
                        let known: Vec<_> = ALL.iter().map(|a| a.name()).collect();
                        format!(
                            "unknown AOV '{name}'; use default, all, beauty or a list of: {}",
                            known.join(", ")
                        )
                    })
                })
                .collect::<Result<Vec<_>, _>>()?,
        };
        aovs.sort();
        aovs.dedup();
        Ok(Self(aovs))
    }
}

impl fmt::Display for AovSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names: Vec<_> = self.0.iter().map(|a| a.name()).collect();
        if names.is_empty() {
            write!(f, "beauty")
        } else {
            write!(f, "{}", names.join(","))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sets_parse_sorted_and_unknown_names_are_refused() {
        let set: AovSet = "Z,albedo,Z,diffuse_direct".parse().unwrap();
        assert_eq!(set.aovs(), [Aov::DiffuseDirect, Aov::Albedo, Aov::Z]);
        assert_eq!(set.to_string(), "diffuse_direct,albedo,Z");
        assert!("beauty".parse::<AovSet>().unwrap().aovs().is_empty());
        assert_eq!("all".parse::<AovSet>().unwrap().aovs(), ALL);
        let err = "diffuse,Z".parse::<AovSet>().unwrap_err();
        assert!(err.contains("unknown AOV 'diffuse'") && err.contains("diffuse_direct"));
    }

    #[test]
    fn primvar_aovs_round_trip_through_set_text_and_take_slots_in_order() {
        let primvar = |name, width| Aov::Primvar { name, width };
        let set: AovSet = [primvar(0xbeef, 1), Aov::Z, primvar(0x12, 3)]
            .into_iter()
            .collect();
        assert_eq!(set.to_string(), "Z,primvar_00000012_3,primvar_0000beef_1");
        assert_eq!(set.to_string().parse::<AovSet>().unwrap(), set);
        assert_eq!(set.primvar_slot(primvar(0x12, 3)), Some(0));
        assert_eq!(set.primvar_slot(primvar(0xbeef, 1)), Some(1));
        assert_eq!(set.primvar_slot(Aov::Z), None);
        assert_eq!(primvar(0xbeef, 1).channels(), ["primvar_0000beef_1"]);
        assert_eq!(
            primvar(0x12, 2).channels(),
            ["primvar_00000012_2.R", "primvar_00000012_2.G"]
        );
        assert!("primvar_12_4".parse::<AovSet>().is_err());
        assert_eq!(primvar_of("primvars:Cd", "raw"), Some("Cd"));
        assert_eq!(primvar_of("Cd", "primvar"), Some("Cd"));
        assert_eq!(primvar_of("Cd", "raw"), None);
    }

    #[test]
    fn channel_names_follow_the_compositing_conventions() {
        assert_eq!(Aov::N.channels(), ["N.X", "N.Y", "N.Z"]);
        assert_eq!(Aov::Z.channels(), ["Z"]);
        assert_eq!(
            Aov::VolumeIndirect.channels(),
            [
                "volume_indirect.R",
                "volume_indirect.G",
                "volume_indirect.B"
            ]
        );
        assert_eq!(Aov::Albedo.pixel_type(), PixelType::Half);
        assert_eq!(Aov::P.pixel_type(), PixelType::Float);
    }

    #[test]
    fn contributions_go_to_one_light_path_each_and_sum_to_the_total() {
        let mut sample = AovSample::default();
        let diffuse = [Vec3::ONE, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO];
        let mixed = [
            Vec3::splat(0.25),
            Vec3::splat(0.5),
            Vec3::splat(0.25),
            Vec3::ZERO,
        ];
        let volume = [Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ONE];
        sample.add(Vec3::splat(1.0), 0, &mixed);
        sample.add(Vec3::splat(2.0), 1, &diffuse);
        sample.add(Vec3::splat(4.0), 2, &mixed);
        sample.add(Vec3::splat(8.0), 1, &volume);
        sample.add(Vec3::splat(16.0), 3, &volume);
        let expected = [1.0, 2.0, 1.0, 0.0, 2.0, 1.0, 8.0, 16.0];
        for (value, want) in sample.light_paths.iter().zip(expected) {
            assert_eq!(*value, Vec3::splat(want));
        }
        let total: Vec3 = sample.light_paths.iter().sum();
        assert_eq!(total, Vec3::splat(31.0));
    }
}
