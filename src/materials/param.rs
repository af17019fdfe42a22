//! A material input as the renderer evaluates it at each hit: a constant, a
//! texture lookup, a mesh primvar interpolated across the triangle (else
//! the hit instance's value of it, else the reader's fallback), or an
//! operation on other inputs (MaterialX `multiply`, `add`, `subtract`,
//! `mix`), the shapes `exporter/FORMAT.md` gives ("Input grammar"). Both
//! UsdPreviewSurface and OpenPBR inputs are [`Param`]s; a constant costs one
//! `match` arm, as it did when inputs were constant or textured only.

use std::ops::{Add, Mul, Sub};

use glam::{Vec3, Vec4};

use super::primvars::{InstancePrimvars, MeshPrimvars, PrimvarNames, NO_INSTANCE_PRIMVARS};
use super::texture::Texture;
use crate::geometry::MeshSite;
use crate::scene::{Channel, Input, Op};

/// A material input of value type `T` (`f32` or a colour `Vec3`).
#[derive(Clone, Debug)]
pub(crate) enum Param<T> {
    /// The authored (or default) value.
    Constant(T),
    /// Index into [`Lookups::textures`] and the output read.
    Texture { texture: u32, channel: Channel },
    /// A primvar (its [`PrimvarNames`] id), the component(s) read, and the
    /// value where neither the mesh nor its instance has it.
    Primvar {
        primvar: u32,
        channel: Channel,
        fallback: T,
    },
    /// An operation on [`Op::arity`] arguments, in MaterialX order.
    Op { op: Op, args: Box<[Param<T>]> },
}

/// What an input's value can be: a scalar, or a colour that scalars
/// broadcast to (a colour input reads every argument as a colour, a
/// single channel as grey, so componentwise maths broadcasts).
pub(crate) trait Value:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self>
{
    /// 1 (white): `mix` weighs its background by one minus the mix.
    const ONE: Self;

    /// Output `channel` of an rgba lookup: a scalar reads `r` for `rgb`; a
    /// colour reads `rgb` as is and a single channel as grey.
    fn pick(rgba: Vec4, channel: Channel) -> Self;
}

impl Value for f32 {
    const ONE: Self = 1.0;

    fn pick(rgba: Vec4, channel: Channel) -> Self {
        match channel {
            Channel::Rgb | Channel::R => rgba.x,
            Channel::G => rgba.y,
            Channel::B => rgba.z,
            Channel::A => rgba.w,
        }
    }
}

impl Value for Vec3 {
    const ONE: Self = Vec3::ONE;

    fn pick(rgba: Vec4, channel: Channel) -> Self {
        match channel {
            Channel::Rgb => rgba.truncate(),
            single => Vec3::splat(f32::pick(rgba, single)),
        }
    }
}

/// Everything inputs read besides their constants: the scene's textures
/// and the primvars of its meshes and instances.
#[derive(Clone, Copy)]
pub(crate) struct Lookups<'a> {
    pub(crate) textures: &'a [Texture],
    /// By scene mesh index.
    pub(crate) primvars: &'a [MeshPrimvars],
    /// By instance index.
    pub(crate) instances: &'a InstancePrimvars,
}

impl<'a> From<&'a [Texture]> for Lookups<'a> {
    /// Textures only: every primvar input reads its fallback.
    fn from(textures: &'a [Texture]) -> Self {
        Self {
            textures,
            primvars: &[],
            instances: &NO_INSTANCE_PRIMVARS,
        }
    }
}

impl Lookups<'_> {
    /// Primvar `id` at `site` as rgba: the mesh's own, else its instance's
    /// (a primvar authored on a prim overrides one it inherits, USD's rule,
    /// the instancer counting as the ancestor of its prototypes' prims);
    /// `None` when neither has it.
    pub(crate) fn primvar(&self, id: u32, site: &MeshSite) -> Option<Vec4> {
        self.primvars
            .get(site.mesh as usize)
            .and_then(|mesh| mesh.eval(id, site.triangle, site.barycentrics))
            .or_else(|| self.instances.eval(id, site.instance))
    }
}

impl<T: Value> Param<T> {
    /// The input's value at `site`. A constant is read inline, at the
    /// cost of a constant-only input.
    #[inline(always)]
    pub(crate) fn eval(&self, lookups: &Lookups, site: &MeshSite) -> T {
        match self {
            Param::Constant(v) => *v,
            varying => varying.eval_varying(lookups, site),
        }
    }

    /// [`Self::eval`] of a texture, primvar or operation (recursive, so
    /// kept out of line).
    fn eval_varying(&self, lookups: &Lookups, site: &MeshSite) -> T {
        match self {
            Param::Constant(v) => *v,
            Param::Texture { texture, channel } => {
                T::pick(lookups.textures[*texture as usize].eval(site.uv), *channel)
            }
            Param::Primvar {
                primvar,
                channel,
                fallback,
            } => lookups
                .primvar(*primvar, site)
                .map_or(*fallback, |v| T::pick(v, *channel)),
            Param::Op { op, args } => {
                let arg = |i: usize| args[i].eval(lookups, site);
                match op {
                    Op::Multiply => arg(0) * arg(1),
                    Op::Add => arg(0) + arg(1),
                    Op::Subtract => arg(0) - arg(1),
                    Op::Mix => {
                        let mix = arg(2);
                        arg(0) * mix + arg(1) * (T::ONE - mix)
                    }
                }
            }
        }
    }

    /// The value when the input is a constant, `None` when it varies.
    pub(crate) fn constant(&self) -> Option<T> {
        match self {
            Param::Constant(v) => Some(*v),
            _ => None,
        }
    }

    /// A record's input (its texture indices validated by the scene
    /// loader), primvar names given ids in `names`.
    pub(crate) fn from_input<R: Copy>(input: &Input<R>, names: &mut PrimvarNames) -> Self
    where
        T: From<R>,
    {
        match input {
            Input::Constant(v) => Param::Constant(T::from(*v)),
            Input::Texture(t) => Param::Texture {
                texture: t.texture,
                channel: t.channel,
            },
            Input::Primvar(p) => Param::Primvar {
                primvar: names.id(&p.primvar),
                channel: p.channel,
                fallback: T::from(p.fallback),
            },
            Input::Op(op) => Param::Op {
                op: op.op,
                args: op
                    .args
                    .iter()
                    .map(|arg| Self::from_input(arg, names))
                    .collect(),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec2;

    use super::*;
    use crate::scene::{OpInput, PrimvarInput, TextureInput};

    /// Mesh 0: one triangle with primvars `w1` (width 1), `w3` and `w4`,
    /// vertex k holding (k+1) * (1, 2, 3, 4) in its first components.
    fn primvars(names: &mut PrimvarNames) -> Vec<MeshPrimvars> {
        let arrays = [("w1", 1), ("w3", 3), ("w4", 4)].map(|(name, width)| {
            let values = (1..=3)
                .flat_map(|k| (1..=width).map(move |c| (k * c) as f32))
                .collect();
            (names.id(name), width, values)
        });
        vec![MeshPrimvars::new(vec![[0, 1, 2]], arrays.into_iter())]
    }

    /// Weights 0.5, 0.25, 0.25: component c interpolates to 1.75 c.
    fn site(mesh: u32) -> MeshSite {
        MeshSite {
            mesh,
            instance: 0,
            triangle: 0,
            barycentrics: Vec2::new(0.25, 0.25),
            uv: Vec2::new(0.5, 0.5),
        }
    }

    fn color(input: Input<[f32; 3]>, names: &mut PrimvarNames) -> Param<Vec3> {
        Param::from_input(&input, names)
    }

    fn primvar<T>(name: &str, channel: Channel, fallback: T) -> Input<T> {
        Input::Primvar(PrimvarInput {
            primvar: name.to_owned(),
            channel,
            fallback,
        })
    }

    fn op<T>(op: Op, args: Vec<Input<T>>) -> Input<T> {
        Input::Op(OpInput { op, args })
    }

    #[test]
    fn constants_textures_and_channels() {
        let textures = [Texture::constant([0.1, 0.2, 0.3, 0.4])];
        let lookups = Lookups::from(&textures[..]);
        let names = &mut PrimvarNames::default();
        let c = color(Input::Constant([1.0, 2.0, 3.0]), names);
        assert_eq!(c.eval(&lookups, &site(0)), Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(c.constant(), Some(Vec3::new(1.0, 2.0, 3.0)));
        let texture = |channel| TextureInput {
            texture: 0,
            channel,
        };
        let rgb = color(Input::Texture(texture(Channel::Rgb)), names);
        assert_eq!(rgb.eval(&lookups, &site(0)), Vec3::new(0.1, 0.2, 0.3));
        assert_eq!(rgb.constant(), None);
        let alpha = color(Input::Texture(texture(Channel::A)), names);
        assert_eq!(alpha.eval(&lookups, &site(0)), Vec3::splat(0.4));
        for (channel, want) in [
            (Channel::Rgb, 0.1),
            (Channel::R, 0.1),
            (Channel::G, 0.2),
            (Channel::B, 0.3),
            (Channel::A, 0.4),
        ] {
            let input: Input<f32> = Input::Texture(texture(channel));
            let scalar: Param<f32> = Param::from_input(&input, names);
            assert_eq!(scalar.eval(&lookups, &site(0)), want, "{channel:?}");
        }
    }

    #[test]
    fn primvars_interpolate_pick_channels_and_fall_back() {
        let names = &mut PrimvarNames::default();
        let meshes = primvars(names);
        let lookups = Lookups {
            textures: &[],
            primvars: &meshes,
            instances: &NO_INSTANCE_PRIMVARS,
        };
        let at = |input: Input<[f32; 3]>, names: &mut PrimvarNames, mesh| {
            color(input, names).eval(&lookups, &site(mesh))
        };
        let fallback = [9.0, 8.0, 7.0];
        // Width 1 read as rgb is grey; widths 3 and 4 give their first three.
        assert_eq!(
            at(primvar("w1", Channel::Rgb, fallback), names, 0),
            Vec3::splat(1.75)
        );
        let three = Vec3::new(1.75, 3.5, 5.25);
        assert_eq!(at(primvar("w3", Channel::Rgb, fallback), names, 0), three);
        assert_eq!(at(primvar("w4", Channel::Rgb, fallback), names, 0), three);
        // A channel of a colour input is grey; alpha of width 3 reads 1.
        assert_eq!(
            at(primvar("w4", Channel::A, fallback), names, 0),
            Vec3::splat(7.0)
        );
        assert_eq!(at(primvar("w3", Channel::A, fallback), names, 0), Vec3::ONE);
        let mut scalar = |name, channel| {
            let input = primvar(name, channel, -1.0);
            Param::<f32>::from_input(&input, names).eval(&lookups, &site(0))
        };
        assert_eq!(scalar("w4", Channel::B), 5.25);
        assert_eq!(scalar("w3", Channel::Rgb), 1.75);
        assert_eq!(scalar("w1", Channel::G), 1.75);
        // A primvar this mesh lacks, and a mesh without primvars.
        assert_eq!(scalar("missing", Channel::R), -1.0);
        let fallback_rgb = Vec3::from(fallback);
        assert_eq!(
            at(primvar("w3", Channel::Rgb, fallback), names, 1),
            fallback_rgb
        );
    }

    #[test]
    fn a_meshs_own_primvar_wins_over_its_instances_then_the_fallback() {
        let names = &mut PrimvarNames::default();
        let meshes = primvars(names);
        // `w3` on instance 2 only, (0.5, 0.25, 0.125).
        let w3 = names.id("w3") as usize;
        let mut by_id = vec![Vec::new(); w3 + 1];
        by_id[w3] = vec![(2, 3, vec![0.5, 0.25, 0.125])];
        let instances = InstancePrimvars::from_runs(by_id);
        let lookups = Lookups {
            textures: &[],
            primvars: &meshes,
            instances: &instances,
        };
        let input = color(primvar("w3", Channel::Rgb, [9.0, 8.0, 7.0]), names);
        let at = |mesh, instance| {
            input.eval(
                &lookups,
                &MeshSite {
                    instance,
                    ..site(mesh)
                },
            )
        };
        // Mesh 0 has w3: its own value on every instance.
        assert_eq!(at(0, 2), Vec3::new(1.75, 3.5, 5.25));
        // Mesh 1 has none: instance 2's value, else the fallback.
        assert_eq!(at(1, 2), Vec3::new(0.5, 0.25, 0.125));
        assert_eq!(at(1, 3), Vec3::new(9.0, 8.0, 7.0));
    }

    #[test]
    fn ops_broadcast_scalars_and_mix_in_materialx_order() {
        let textures = [Texture::constant([0.5, 0.25, 1.0, 0.75])];
        let lookups = Lookups::from(&textures[..]);
        let names = &mut PrimvarNames::default();
        let grey = |v: f32| Input::Constant([v; 3]);
        fn tex<T>(channel: Channel) -> Input<T> {
            Input::Texture(TextureInput {
                texture: 0,
                channel,
            })
        }
        let eval = |input, names: &mut PrimvarNames| color(input, names).eval(&lookups, &site(0));
        let rgb = Vec3::new(0.5, 0.25, 1.0);
        let cases = [
            (
                op(Op::Multiply, vec![tex(Channel::Rgb), grey(2.0)]),
                rgb * 2.0,
            ),
            (op(Op::Add, vec![grey(1.0), tex(Channel::Rgb)]), rgb + 1.0),
            (
                op(Op::Subtract, vec![tex(Channel::Rgb), grey(0.25)]),
                rgb - 0.25,
            ),
            // mix(fg, bg, m) = fg m + bg (1 - m), m from alpha (0.75).
            (
                op(Op::Mix, vec![grey(1.0), tex(Channel::Rgb), tex(Channel::A)]),
                0.75 + rgb * 0.25,
            ),
            // Nested: (rgb - r) * 4.
            (
                op(
                    Op::Multiply,
                    vec![
                        op(Op::Subtract, vec![tex(Channel::Rgb), tex(Channel::R)]),
                        grey(4.0),
                    ],
                ),
                (rgb - 0.5) * 4.0,
            ),
        ];
        for (input, want) in cases {
            let got = eval(input.clone(), names);
            assert!(
                (got - want).abs().max_element() < 1e-6,
                "{input:?}: {got} vs {want}"
            );
        }
        // A scalar input: the same maths on one channel.
        let scalar = op(
            Op::Mix,
            vec![Input::Constant(1.0), tex(Channel::G), Input::Constant(0.5)],
        );
        let value = Param::<f32>::from_input(&scalar, names).eval(&lookups, &site(0));
        assert_eq!(value, 0.625);
    }
}
