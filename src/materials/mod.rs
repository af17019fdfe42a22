//! UsdPreviewSurface
//! (<https://openusd.org/release/spec_usdpreviewsurface.html>) and OpenPBR
//! Surface materials, their textures and the mesh primvars they read.
//!
//! [`Materials::build`] reads every `UsdUVTexture` image once (texture.rs:
//! bilinear, wrap modes, `st` transform, scale and bias), copies the mesh
//! primvars material inputs name (primvars.rs) and resolves every
//! material's inputs (param.rs: constants, textures, primvars and per-hit
//! maths); [`Materials::bsdf`] evaluates them at a hit, for a
//! UsdPreviewSurface (preview_surface.rs) into a layered [`Bsdf`] (bsdf.rs, sampled in
//! bsdf_sample.rs): clearcoat over GGX specular over Lambert, plus a rough
//! dielectric where opacity < 1 (the lobes: lobes.rs). GGX uses Smith
//! height-correlated masking-shadowing (Heitz 2014) and visible-normal
//! sampling through spherical caps (Dupuy and Benyoub 2023); refraction
//! follows Walter et al. 2007; shading normals that face away from `wo` are
//! bent as in Iray (Keller et al. 2017). An OpenPBR record
//! (open_pbr_surface.rs) evaluates to `OpenPbrInputs` and shading frames,
//! and `Bsdf::from_open_pbr` (open_pbr/) builds its BSDF.
//!
//! A material made for a mesh light (`UsdLuxMeshLightAPI`, the record's
//! `light`) emits its emission times the light's colour, intensity,
//! exposure and colour temperature ([`Materials::emission`]), and carries
//! the light's diffuse and specular factors ([`Materials::light_lobes`]).

mod bsdf;
mod bsdf_sample;
mod fresnel;
mod lobes;
mod microfacet;
mod open_pbr;
mod open_pbr_surface;
mod param;
mod preview_surface;
mod primvars;
mod scatter;
mod texture;

#[cfg(test)]
mod open_pbr_tests;
#[cfg(test)]
mod test_support;

pub use bsdf::Bsdf;
pub use lobes::LobeValues;
pub use scatter::BsdfSample;

use glam::{Vec3, Vec4};
use thiserror::Error;

use crate::color::blackbody_rgb;
use crate::geometry::{MeshSite, SurfacePoint};
use crate::scene::{GeometryLight, LightLobes, Model, Scene, NO_MATERIAL};
use open_pbr_surface::OpenPbrSurface;
use param::Lookups;
use preview_surface::PreviewSurface;
use primvars::{InstancePrimvars, MeshPrimvars, PrimvarNames};
use texture::Texture;

/// Every material and texture of a scene, ready to build BSDFs at hits.
pub struct Materials {
    surfaces: Vec<Surface>,
    /// What a surface with [`NO_MATERIAL`] looks like.
    unbound: Surface,
    textures: Vec<Texture>,
    /// By scene mesh: the primvars material inputs and AOVs read.
    primvars: Vec<MeshPrimvars>,
    /// By instance: the values a mesh without the primvar reads.
    instance_primvars: InstancePrimvars,
    /// Their names' ids.
    primvar_names: PrimvarNames,
    /// By material: what a mesh light's LightAPI makes of it (`None` for a
    /// plain material; empty when no material is a mesh light's).
    lights: Vec<Option<MaterialLight>>,
    /// Some material's `opacityThreshold` can cut its surface out.
    cut_outs: bool,
}

/// What a mesh light's LightAPI inputs make of its material.
#[derive(Clone, Copy, Debug)]
struct MaterialLight {
    /// Factor on the material's emission: `scale` x blackbody(colorTemperature).
    emission: Vec3,
    /// The light's diffuse and specular factors.
    lobes: LightLobes,
}

/// A material's surface model.
#[derive(Clone, Debug)]
enum Surface {
    Preview(PreviewSurface),
    OpenPbr(Box<OpenPbrSurface>),
}

/// A material that cannot be used.
#[derive(Debug, Error)]
pub enum MaterialError {
    /// `inputs:ior` is not a positive finite number, so no Fresnel or
    /// refraction can be computed.
    #[error("material {material}: ior {ior} is not a positive number")]
    InvalidIor {
        /// Prim path of the Material.
        material: String,
        /// The value read.
        ior: f32,
    },
    /// A mesh light's emission scale is not finite and non-negative, or its
    /// colour temperature is not a positive number.
    #[error("light {light}: {message}")]
    InvalidLight {
        /// Prim path of the gprim that is a light.
        light: String,
        /// What is wrong.
        message: String,
    },
}

impl Materials {
    /// Reads every texture file once and resolves every material's inputs.
    /// A missing or unreadable texture file is not an error: its lookups
    /// return the texture's `fallback` and one warning names the file.
    pub fn build(scene: &Scene) -> Result<Self, MaterialError> {
        let m = &scene.manifest;
        if let Some(bad) = m
            .materials
            .iter()
            .find(|r| !(r.ior.is_finite() && r.ior > 0.0))
        {
            return Err(MaterialError::InvalidIor {
                material: bad.path.clone(),
                ior: bad.ior,
            });
        }
        let mut names = PrimvarNames::default();
        let surfaces = m
            .materials
            .iter()
            .map(|record| match record.model {
                Model::PreviewSurface => {
                    Surface::Preview(PreviewSurface::from_record(record, &mut names))
                }
                Model::OpenPbr => {
                    Surface::OpenPbr(Box::new(OpenPbrSurface::from_record(record, &mut names)))
                }
            })
            .collect::<Vec<_>>();
        let cut_outs = surfaces
            .iter()
            .any(|s| matches!(s, Surface::Preview(p) if p.opacity_threshold > 0.0));
        names.add_carried(scene);
        let lights = if m.materials.iter().any(|r| r.light.is_some()) {
            let light = |r: &crate::scene::Material| r.light.as_ref().map(MaterialLight::new);
            m.materials
                .iter()
                .map(|r| light(r).transpose())
                .collect::<Result<_, _>>()?
        } else {
            Vec::new()
        };
        Ok(Self {
            surfaces,
            unbound: Surface::Preview(PreviewSurface::default_surface()),
            textures: Texture::load_all(&m.textures),
            primvars: MeshPrimvars::build_all(scene, &names),
            instance_primvars: InstancePrimvars::build(scene, &names),
            primvar_names: names,
            lights,
            cut_outs,
        })
    }

    /// Whether some material's `opacityThreshold` can cut its surface out
    /// ([`Self::is_cut_out`]); when none can, every hit is a surface.
    pub fn has_cut_outs(&self) -> bool {
        self.cut_outs
    }

    /// Whether `material` is cut out at `site` (UsdPreviewSurface opacity
    /// below a positive `opacityThreshold`): rays pass such a hit as if
    /// nothing were there, neither shading nor shadowing it.
    pub fn is_cut_out(&self, material: u32, site: &MeshSite) -> bool {
        match self.surface(material) {
            Surface::Preview(s) => s.is_cut_out(&self.lookups(), site),
            Surface::OpenPbr(_) => false,
        }
    }

    /// The id of the primvar `name` when some mesh, points or curves prim
    /// carries it, for [`Self::primvar`].
    pub fn primvar_id(&self, name: &str) -> Option<u32> {
        self.primvar_names.find(name)
    }

    /// Primvar `id` at `site` as rgba (width 1 is grey, missing components
    /// 0, alpha 1; see `MeshPrimvars::eval`): the mesh's, else its
    /// instance's; `None` where neither has it.
    pub fn primvar(&self, id: u32, site: &MeshSite) -> Option<Vec4> {
        self.lookups().primvar(id, site)
    }

    /// The BSDF of `sp`'s material at `sp`, for the outgoing direction `wo`
    /// (unit, world, away from the surface). `wo` fixes the side of the
    /// surface, the shading normal's correction and the lobe probabilities,
    /// so the returned BSDF is for this `wo` only.
    pub fn bsdf(&self, sp: &SurfacePoint, wo: Vec3) -> Bsdf {
        let lookups = self.lookups();
        match self.surface(sp.material) {
            Surface::Preview(s) => Bsdf::new(s.shading(lookups, sp, wo), wo),
            Surface::OpenPbr(s) => s.bsdf(&lookups, sp, wo),
        }
    }

    /// What `material` emits at `site`: radiance in W/(m^2 sr), linear
    /// Rec.709, leaving the front side (the caller decides sidedness):
    /// UsdPreviewSurface's `emissiveColor`, OpenPBR's `emission_luminance`
    /// times `emission_color`; for a mesh light's material, times the
    /// light's scale. Black for [`NO_MATERIAL`].
    pub fn emission(&self, material: u32, site: &MeshSite) -> Vec3 {
        let lookups = &self.lookups();
        let emitted = match self.surface(material) {
            // Where a cut-out leaves no surface, nothing emits either.
            Surface::Preview(s) if s.is_cut_out(lookups, site) => Vec3::ZERO,
            Surface::Preview(s) => s.emissive_color.eval(lookups, site).max(Vec3::ZERO),
            Surface::OpenPbr(s) => s.emission(lookups, site),
        };
        match self.light(material) {
            Some(light) => emitted * light.emission,
            None => emitted,
        }
    }

    /// The diffuse and specular factors of the mesh light whose material
    /// `material` is (1 and 1 for any other material).
    pub fn light_lobes(&self, material: u32) -> LightLobes {
        self.light(material)
            .map_or_else(LightLobes::default, |l| l.lobes)
    }

    /// Whether some material is a mesh light's with a diffuse or specular
    /// factor other than 1.
    pub fn any_light_lobes(&self) -> bool {
        self.lights.iter().flatten().any(|l| l.lobes.scales())
    }

    fn light(&self, material: u32) -> Option<&MaterialLight> {
        self.lights.get(material as usize)?.as_ref()
    }

    /// The absorption coefficient (per scene unit, RGB) of the interior
    /// behind `material`'s surface at `site`: an OpenPBR thick dielectric
    /// with `transmission_depth` > 0 (`open_pbr/medium.rs`); `None` for a
    /// clear interior.
    pub fn interior_absorption(&self, material: u32, site: &MeshSite) -> Option<Vec3> {
        match self.surface(material) {
            Surface::Preview(_) => None,
            Surface::OpenPbr(s) => s.interior_absorption(&self.lookups(), site),
        }
    }

    /// Whether `material` can emit: its emission varies (texture, primvar,
    /// maths) or is a non-black constant.
    pub fn is_emissive(&self, material: u32) -> bool {
        match self.surface(material) {
            Surface::Preview(s) => s.is_emissive(),
            Surface::OpenPbr(s) => s.is_emissive(),
        }
    }

    /// What inputs read besides their constants.
    fn lookups(&self) -> Lookups<'_> {
        Lookups {
            textures: &self.textures,
            primvars: &self.primvars,
            instances: &self.instance_primvars,
        }
    }

    /// The surface for a material index ([`NO_MATERIAL`] = the defaults).
    fn surface(&self, material: u32) -> &Surface {
        if material == NO_MATERIAL {
            &self.unbound
        } else {
            &self.surfaces[material as usize]
        }
    }
}

impl MaterialLight {
    /// The record's scale times the blackbody colour (luminance 1) of its
    /// colour temperature, as a UsdLux light's emission
    /// (docs/conventions.md, "Lights"); unusable values are refused.
    fn new(record: &GeometryLight) -> Result<Self, MaterialError> {
        let invalid = |message: String| MaterialError::InvalidLight {
            light: record.path.clone(),
            message,
        };
        let tint = match record.color_temperature {
            Some(t) if !(t.is_finite() && t > 0.0) => {
                return Err(invalid(format!(
                    "colorTemperature {t} K is not a positive number"
                )))
            }
            Some(t) => blackbody_rgb(t),
            None => Vec3::ONE,
        };
        let emission = Vec3::from(record.scale) * tint;
        if !emission.is_finite() || emission.min_element() < 0.0 {
            return Err(invalid(format!(
                "emission scale {emission} (color x intensity x 2^exposure) is not finite and non-negative"
            )));
        }
        Ok(Self {
            emission,
            lobes: record.lobes,
        })
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec2;

    use super::param::Param;
    use super::*;
    use crate::scene::{self, Input, Material, PrimvarInput};

    const SITE: MeshSite = MeshSite {
        mesh: 0,
        instance: 0,
        triangle: 0,
        barycentrics: Vec2::ZERO,
        uv: Vec2::new(0.3, 0.4),
    };

    fn materials(surfaces: Vec<Surface>) -> Materials {
        Materials {
            surfaces,
            unbound: Surface::Preview(PreviewSurface::default_surface()),
            textures: Vec::new(),
            primvars: Vec::new(),
            instance_primvars: InstancePrimvars::default(),
            primvar_names: PrimvarNames::default(),
            lights: Vec::new(),
            cut_outs: false,
        }
    }

    /// An OpenPBR record with `edit` applied to its inputs.
    fn open_pbr(edit: impl FnOnce(&mut scene::OpenPbr)) -> Surface {
        let mut record = Material {
            model: Model::OpenPbr,
            ..Material::default()
        };
        edit(&mut record.open_pbr);
        let names = &mut PrimvarNames::default();
        Surface::OpenPbr(Box::new(OpenPbrSurface::from_record(&record, names)))
    }

    #[test]
    fn unbound_surfaces_are_grey_and_dark_and_emitters_emit() {
        let lamp = PreviewSurface {
            emissive_color: Param::Constant(Vec3::new(1.0, 2.0, 3.0)),
            ..PreviewSurface::default_surface()
        };
        let materials = materials(vec![
            Surface::Preview(PreviewSurface::default_surface()),
            Surface::Preview(lamp),
        ]);
        assert!(!materials.is_emissive(NO_MATERIAL) && !materials.is_emissive(0));
        assert_eq!(materials.emission(NO_MATERIAL, &SITE), Vec3::ZERO);
        assert!(materials.is_emissive(1));
        assert_eq!(materials.emission(1, &SITE), Vec3::new(1.0, 2.0, 3.0));
    }

    /// OpenPBR emits luminance times colour, and only when neither is a
    /// constant zero; a primvar-driven colour (here its fallback) emits.
    #[test]
    fn open_pbr_emission_is_luminance_times_colour() {
        let materials = materials(vec![
            open_pbr(|_| {}),
            open_pbr(|r| {
                r.emission_luminance = Some(Input::Constant(2.0));
                r.emission_color = Some(Input::Constant([0.5, 0.25, 1.0]));
            }),
            open_pbr(|r| {
                r.emission_luminance = Some(Input::Constant(2.0));
                r.emission_color = Some(Input::Constant([0.0; 3]));
            }),
            open_pbr(|r| {
                r.emission_luminance = Some(Input::Constant(3.0));
                r.emission_color = Some(Input::Primvar(PrimvarInput {
                    primvar: "glow".to_owned(),
                    channel: scene::Channel::Rgb,
                    fallback: [0.0, 1.0, 0.0],
                }));
            }),
        ]);
        let emissive: Vec<bool> = (0..4).map(|m| materials.is_emissive(m)).collect();
        assert_eq!(emissive, [false, true, false, true]);
        assert_eq!(materials.emission(1, &SITE), Vec3::new(1.0, 0.5, 2.0));
        assert_eq!(materials.emission(3, &SITE), Vec3::new(0.0, 3.0, 0.0));
    }
}
