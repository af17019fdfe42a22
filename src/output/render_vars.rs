//! USD `RenderVar`s as EXR layers: which of our AOVs (or sums of them) a
//! var's `sourceName` names, and the layer's channels, named by the var's
//! prim name as husk names them (`diffuse.R`, `depth`, `crypto_object00.R`;
//! a beauty var stays the unprefixed `R, G, B, A`).
//!
//! A primvar (`sourceType` `primvar`, or `sourceName` `primvars:NAME`) is
//! the primvar's value on the camera ray's first surface hit, averaged like
//! `N`: `dataType` `float` writes one channel (`<name>`), `float2` two
//! (`.R, .G`), `float3`/`color3f` (and wider) three (`.R, .G, .B`).
//!
//! Light path expressions (`sourceType` `lpe`, or a `lpe:` prefix) name a
//! light-path AOV by its first event after the camera (see `film/aov.rs`):
//! `<RD>` diffuse reflection, `<RS>`/`<RG>`/`<R[GS]>` glossy or specular
//! reflection (one class for us), `<T.>` any transmission, `<V.>` volume
//! scattering; then `L` (direct: nothing more before the light), `.+L`
//! (indirect) or `.*L` (both: the sum of the two AOVs). `L` may be written
//! `[LO]`: our lights include emissive surfaces. `CL` is the emission AOV and
//! `C.*L` the beauty. The table is in `docs/rendering.md`.

use crate::film::{murmur3_32, primvar_of, Aov};
use crate::image::PixelType;

/// The layers of an EXR.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum Layers {
    /// The film's own: beauty RGBA and each AOV under its name.
    #[default]
    Film,
    /// A render product's, one per supported `RenderVar`, in order.
    Named(Vec<NamedLayer>),
}

/// What one EXR layer holds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LayerSource {
    /// The beauty: `R, G, B` and alpha `A`, unprefixed.
    Beauty,
    /// The sum of these AOVs' layers: one AOV, or the direct and indirect
    /// halves of a light-path class.
    Aovs(Vec<Aov>),
}

/// A `RenderVar`'s layer.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NamedLayer {
    /// The var's prim name: channels are `<name>.R` etc. (one-channel
    /// layers are `<name>` alone).
    pub name: String,
    /// What the layer holds.
    pub source: LayerSource,
    /// Storage asked for by `dataType` (Cryptomattes are always float).
    pub pixel_type: PixelType,
}

impl NamedLayer {
    /// The AOVs the film must accumulate for this layer.
    pub fn aovs(&self) -> &[Aov] {
        match &self.source {
            LayerSource::Beauty => &[],
            LayerSource::Aovs(aovs) => aovs,
        }
    }
}

/// A `RenderVar`'s attributes, as authored.
#[derive(Clone, Copy, Debug)]
pub struct VarAttributes<'a> {
    /// The var's prim name: the layer's name.
    pub name: &'a str,
    /// `sourceName`.
    pub source_name: &'a str,
    /// `sourceType`: `raw`, `primvar`, `lpe` or `intrinsic`.
    pub source_type: &'a str,
    /// `dataType`.
    pub data_type: &'a str,
}

/// The layer of the var `var`, or why it is skipped (a sentence naming
/// the value at fault, for one warning that names the var).
pub fn layer_of(var: &VarAttributes) -> Result<NamedLayer, String> {
    let name: String = var.source_name.split_whitespace().collect();
    let (components, half) = components(var.data_type)
        .ok_or_else(|| format!("dataType {:?} is not a float type", var.data_type))?;
    let source = match (var.source_type, name.strip_prefix("lpe:")) {
        (_, Some(lpe)) => light_path(lpe),
        ("lpe", None) => light_path(&name),
        _ => match primvar_of(&name, var.source_type) {
            Some(primvar) => Some(LayerSource::Aovs(vec![Aov::Primvar {
                name: murmur3_32(primvar.as_bytes(), 0),
                width: components.min(3) as u8,
            }])),
            None => named_source(&name),
        },
    }
    .ok_or_else(|| {
        format!(
            "sourceName {:?} ({}) is not one Cirrus produces (see docs/rendering.md, USD render settings)",
            var.source_name, var.source_type
        )
    })?;
    let needed = match &source {
        LayerSource::Beauty => 3,
        LayerSource::Aovs(aovs) => match aovs[0] {
            Aov::Z | Aov::SampleCount | Aov::Primvar { .. } => 1,
            aov if is_crypto(aov) => 1,
            _ => 3,
        },
    };
    if components < needed {
        return Err(format!(
            "dataType {:?} has {components} channel(s); {:?} needs {needed}",
            var.data_type, var.source_name
        ));
    }
    let crypto = matches!(&source, LayerSource::Aovs(a) if is_crypto(a[0]));
    let pixel_type = if half && !crypto {
        PixelType::Half
    } else {
        PixelType::Float
    };
    Ok(NamedLayer {
        name: var.name.to_string(),
        source,
        pixel_type,
    })
}

/// Whether `aov` is a Cryptomatte (its channels are ids: never half).
fn is_crypto(aov: Aov) -> bool {
    matches!(
        aov,
        Aov::CryptoObject | Aov::CryptoMaterial | Aov::CryptoAsset
    )
}

/// A raw or intrinsic `sourceName`: `P`, `N`, `depth`, `albedo`, the
/// Cryptomattes, the beauty (`Ci`, `color`) or any of our AOV names; else
/// a light path expression written without `lpe:`.
fn named_source(name: &str) -> Option<LayerSource> {
    let aov = match name {
        "Ci" | "color" | "beauty" => return Some(LayerSource::Beauty),
        "Nn" | "normal" => Aov::N,
        "depth" | "z" | "hitDepth" => Aov::Z,
        "crypto_object" | "cryptomatte_object" => Aov::CryptoObject,
        "crypto_material" | "cryptomatte_material" => Aov::CryptoMaterial,
        "crypto_asset" | "cryptomatte_asset" => Aov::CryptoAsset,
        _ => match crate::film::ALL_AOVS.into_iter().find(|a| a.name() == name) {
            Some(aov) => aov,
            None => return light_path(name),
        },
    };
    Some(LayerSource::Aovs(vec![aov]))
}

/// The layer a light path expression (whitespace removed, no `lpe:`) names.
fn light_path(lpe: &str) -> Option<LayerSource> {
    use Aov::*;
    let rest = lpe.strip_prefix('C')?;
    let (event, tail) = match rest.strip_prefix('<') {
        Some(inside) => {
            let (event, tail) = inside.split_once('>')?;
            (Some(event), tail)
        }
        None => (None, rest),
    };
    let ending = ["[LO]", "[OL]", "L"]
        .into_iter()
        .find_map(|light| tail.strip_suffix(light));
    // Which of the direct (0) and indirect (1) halves: `L`, `.+L`, `.*L` (or `.*`).
    let halves: &[usize] = match (ending, tail) {
        (Some(""), _) => &[0],
        (Some(".+"), _) => &[1],
        (Some(".*"), _) | (None, ".*") => &[0, 1],
        _ => return None,
    };
    let classes: &[[Aov; 2]] = match event {
        None if halves == [0, 1] => return Some(LayerSource::Beauty),
        None if halves == [0] => return Some(LayerSource::Aovs(vec![Emission])),
        Some("RD") => &[[DiffuseDirect, DiffuseIndirect]],
        Some("RS" | "RG" | "R[GS]" | "R[SG]") => &[[SpecularDirect, SpecularIndirect]],
        Some("R" | "R.") => &[
            [DiffuseDirect, DiffuseIndirect],
            [SpecularDirect, SpecularIndirect],
        ],
        Some("T" | "T." | "TD" | "TS" | "TG" | "T[GS]" | "T[SG]") if halves == [0, 1] => {
            return Some(LayerSource::Aovs(vec![Transmission]))
        }
        Some("V" | "V." | "VD") => &[[VolumeDirect, VolumeIndirect]],
        _ => return None,
    };
    let aovs = classes
        .iter()
        .flat_map(|pair| halves.iter().map(|&h| pair[h]))
        .collect();
    Some(LayerSource::Aovs(aovs))
}

/// Channels and half precision of a float `dataType`; `None` for others
/// (ints, strings, bools, matrices).
fn components(data_type: &str) -> Option<(usize, bool)> {
    let (base, count, suffix) = match data_type.find(|c: char| c.is_ascii_digit()) {
        None => (data_type, 1, ""),
        Some(i) => (
            &data_type[..i],
            data_type[i..i + 1].parse().ok()?,
            &data_type[i + 1..],
        ),
    };
    let precision = match (base, suffix) {
        ("float" | "half" | "double", "") => base,
        ("color" | "vector" | "normal" | "point" | "texCoord", "f") => "float",
        ("color" | "vector" | "normal" | "point" | "texCoord", "h") => "half",
        ("color" | "vector" | "normal" | "point" | "texCoord", "d") => "double",
        _ => return None,
    };
    (1..=4)
        .contains(&count)
        .then_some((count, precision == "half"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn var<'a>(
        source_name: &'a str,
        source_type: &'a str,
        data_type: &'a str,
    ) -> VarAttributes<'a> {
        VarAttributes {
            name: "v",
            source_name,
            source_type,
            data_type,
        }
    }

    fn source(source_name: &str, source_type: &str) -> Option<LayerSource> {
        layer_of(&var(source_name, source_type, "color4f"))
            .ok()
            .map(|l| l.source)
    }

    #[test]
    fn light_path_expressions_name_our_light_path_aovs() {
        use Aov::*;
        let aovs = |a: &[Aov]| Some(LayerSource::Aovs(a.to_vec()));
        assert_eq!(source("C.*L", "lpe"), Some(LayerSource::Beauty));
        assert_eq!(source("lpe:C.*", "raw"), Some(LayerSource::Beauty));
        assert_eq!(source("CL", "lpe"), aovs(&[Emission]));
        assert_eq!(
            source("lpe:C<RD>.*L", "raw"),
            aovs(&[DiffuseDirect, DiffuseIndirect])
        );
        assert_eq!(source("C<RD>L", "lpe"), aovs(&[DiffuseDirect]));
        assert_eq!(source("C<RD>[LO]", "lpe"), aovs(&[DiffuseDirect]));
        assert_eq!(source("C<RD>.+L", "lpe"), aovs(&[DiffuseIndirect]));
        assert_eq!(
            source("C<RS>.*L", "lpe"),
            aovs(&[SpecularDirect, SpecularIndirect])
        );
        assert_eq!(source("lpe:C<TD>.*L", "raw"), aovs(&[Transmission]));
        assert_eq!(source("C<V.>.+L", "lpe"), aovs(&[VolumeIndirect]));
        assert_eq!(source("C<TD>L", "lpe"), None, "transmission is not split");
        assert_eq!(source("C<RD>", "lpe"), None);
        assert_eq!(source("C.+L", "lpe"), None);
    }

    #[test]
    fn raw_names_and_data_types() {
        let layer = |n: &str, t: &str| layer_of(&var(n, "raw", t));
        assert_eq!(
            layer("depth", "float").unwrap().source,
            LayerSource::Aovs(vec![Aov::Z])
        );
        assert_eq!(layer("N", "normal3f").unwrap().pixel_type, PixelType::Float);
        assert_eq!(
            layer("albedo", "half3").unwrap().pixel_type,
            PixelType::Half
        );
        assert_eq!(
            layer("crypto_object", "color4h").unwrap().pixel_type,
            PixelType::Float
        );
        assert!(layer("P", "float").unwrap_err().contains("needs 3"));
        assert!(layer("P", "int3").unwrap_err().contains("\"int3\""));
        assert!(layer("P", "string").is_err());
        assert!(layer("nonsense", "color3f")
            .unwrap_err()
            .contains("\"nonsense\""));
        let st = Aov::Primvar {
            name: murmur3_32(b"st", 0),
            width: 2,
        };
        let primvar = |n, t, d| layer_of(&var(n, t, d)).unwrap().source;
        assert_eq!(
            primvar("st", "primvar", "float2"),
            LayerSource::Aovs(vec![st])
        );
        assert_eq!(
            primvar("primvars:st", "raw", "float2"),
            LayerSource::Aovs(vec![st])
        );
        assert_eq!(
            primvar("primvars:st", "raw", "color4f"),
            LayerSource::Aovs(vec![Aov::Primvar {
                name: murmur3_32(b"st", 0),
                width: 3
            }])
        );
        let name = format!("primvar_{:08x}_2", murmur3_32(b"st", 0));
        assert_eq!(st.channels(), [format!("{name}.R"), format!("{name}.G")]);
    }
}
