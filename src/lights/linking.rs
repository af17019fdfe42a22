//! Light and shadow linking (UsdLux `collection:lightLink` and
//! `collection:shadowLink`, resolved by the exporter into link sets,
//! exporter/FORMAT.md "Linking"): which lights light a shading point's
//! [`Receiver`] set, and which placed parts cast a light's shadow.

use glam::Vec3;

use super::{Light, LightError, LightHit, LOG_TARGET};
use crate::scene::{LightLinks, LinkRun, Scene};

/// The link set of the vertex a ray leaves from: which lights may light it
/// (and so be picked, counted and found there).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Receiver(u32);

impl Receiver {
    /// The set of parts no collection names (and of every part when no
    /// light links); points in media are in it too.
    pub const UNNAMED: Self = Self(0);
    /// A camera ray's: the camera sees every light, linked or not.
    pub const CAMERA: Self = Self(u32::MAX);

    /// The receiver of link set `set`.
    pub(super) fn of_set(set: usize) -> Self {
        Self(u32::try_from(set).unwrap_or(u32::MAX - 1))
    }

    /// The link set's index into per-set tables (the camera's shares set 0's).
    pub(super) fn set(self) -> usize {
        if self == Self::CAMERA {
            0
        } else {
            self.0 as usize
        }
    }
}

/// Per light, the sets it lights and those that cast its shadow, and per
/// placed part its set.
#[derive(Debug)]
pub(super) struct Linking {
    /// Per light index: whether it lights each set; `None` = every set.
    lit: Vec<Option<Vec<bool>>>,
    /// Per light index: whether each set casts its shadow; `None` = every set.
    shadow: Vec<Option<Vec<bool>>>,
    /// The manifest's runs of placed parts' sets, increasing by instance.
    runs: Vec<LinkRun>,
    /// Number of sets (1 + the largest id named anywhere).
    sets: usize,
}

/// `ids` as a table of membership by set.
fn members(ids: &[u32]) -> Vec<bool> {
    let mut table = vec![false; ids.iter().max().map_or(0, |&m| m as usize + 1)];
    for &id in ids {
        table[id as usize] = true;
    }
    table
}

impl Linking {
    /// Whether light `light` lights `receiver` (the camera sees every light).
    pub fn lights(&self, light: usize, receiver: Receiver) -> bool {
        receiver == Receiver::CAMERA || in_set(&self.lit[light], receiver.set())
    }

    /// Whether parts of `set` cast the shadow of light `light`.
    pub fn casts_shadow(&self, light: usize, set: Receiver) -> bool {
        in_set(&self.shadow[light], set.set())
    }

    /// Whether some parts are transparent to light `light`'s shadow rays.
    pub fn shadow_linked(&self, light: usize) -> bool {
        self.shadow[light].is_some()
    }

    /// Whether any light's shadow is linked.
    pub fn any_shadow_linked(&self) -> bool {
        self.shadow.iter().any(Option::is_some)
    }

    /// Number of link sets.
    pub fn sets(&self) -> usize {
        self.sets
    }

    /// The set of surface part `part` (`Hit::prototype_mesh`) of `instance`.
    pub fn receiver(&self, instance: u32, part: u32) -> Receiver {
        let instance = u64::from(instance);
        let after = self.runs.partition_point(|r| r.first <= instance);
        let set = after
            .checked_sub(1)
            .map(|i| &self.runs[i])
            .filter(|r| instance < r.first + r.count)
            .and_then(|r| r.parts.get(part as usize).copied());
        Receiver(set.unwrap_or(0))
    }

    /// The linking of `scene` for its lights, each light index's record
    /// links in `links` (`None` for lights no record makes: emissive meshes
    /// and volumes, which link nothing); `None` when no light links, the
    /// fast path. Runs out of order or past the instances are an error;
    /// linked volumes are warned about by name (media are lit and shadowed
    /// by every light).
    pub fn build(scene: &Scene, links: &[Option<&LightLinks>]) -> Result<Option<Self>, LightError> {
        let table = |pick: fn(&LightLinks) -> &Option<Vec<u32>>| -> Vec<Option<Vec<bool>>> {
            links
                .iter()
                .map(|l| l.and_then(|l| pick(l).as_deref().map(members)))
                .collect()
        };
        let (lit, shadow) = (table(|l| &l.light_link), table(|l| &l.shadow_link));
        if lit.iter().chain(&shadow).all(Option::is_none) {
            return Ok(None);
        }
        let instances = &scene.manifest.instances;
        let runs = instances.links.clone();
        let mut end = 0;
        for run in &runs {
            if run.first < end || run.first + run.count > instances.count {
                return Err(LightError::Linking(format!(
                    "link run of instances {}..{} overlaps another or passes the {} instances",
                    run.first,
                    run.first + run.count,
                    instances.count
                )));
            }
            end = run.first + run.count;
        }
        warn_linked_volumes(scene, &runs);
        let largest = runs
            .iter()
            .flat_map(|r| r.parts.iter().chain(&r.volumes))
            .copied()
            .max()
            .unwrap_or(0) as usize;
        let named = lit.iter().chain(&shadow).flatten().map(Vec::len).max();
        let sets = (largest + 1).max(named.unwrap_or(0));
        Ok(Some(Self {
            lit,
            shadow,
            runs,
            sets,
        }))
    }
}

/// Where the ray from `origin` along unit `direction` meets `light` beyond
/// `t_from` at `time` (frames): an analytic area light's front face, or an
/// infinite light (at t = infinity) when `t_from` is finite; pdf without
/// selection.
pub(super) fn hit_beyond(
    light: &Light,
    (origin, direction): (Vec3, Vec3),
    (t_from, time): (f32, f32),
) -> Option<LightHit> {
    match light.intersect(origin, direction, f32::INFINITY, time) {
        Some(hit) => Some(hit).filter(|h| h.t > t_from),
        None if t_from.is_finite() => light.escaped(direction, time).map(|h| LightHit {
            t: f32::INFINITY,
            ..h
        }),
        None => None,
    }
}

/// Whether `set` is in `table` (`None`: every set).
fn in_set(table: &Option<Vec<bool>>, set: usize) -> bool {
    table
        .as_ref()
        .is_none_or(|t| t.get(set).copied().unwrap_or(false))
}

/// One warning per volume whose parts are in a link set other than 0: the
/// media are lit and shadowed by every light (not yet linked).
fn warn_linked_volumes(scene: &Scene, runs: &[LinkRun]) {
    let prototypes = scene.view(&scene.manifest.instances.prototype);
    let mut warned = std::collections::BTreeSet::new();
    for run in runs {
        let Some(&prototype) = prototypes.get(run.first as usize) else {
            continue;
        };
        let parts = &scene.manifest.prototypes[prototype as usize].volumes;
        for (part, _) in parts.iter().zip(&run.volumes).filter(|(_, &s)| s != 0) {
            let path = &scene.manifest.volumes[part.volume as usize].path;
            if warned.insert(path.clone()) {
                log::warn!(
                    target: LOG_TARGET,
                    "volume {path}: a light's collection:lightLink or collection:shadowLink names \
                     it, but volumes are not linked yet: every light lights it and its \
                     transmittance shadows every light"
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Instances 2..5 have their first part in set 2 and second in set 0,
    /// instance 7 its first part in set 1: every other part is in set 0.
    /// Light 0 lights set 2 alone and set 1 casts its shadow; light 1
    /// links nothing; the camera sees both.
    #[test]
    fn parts_find_their_sets_and_lights_their_receivers() {
        let run = |first, count, parts: &[u32]| LinkRun {
            first,
            count,
            parts: parts.to_vec(),
            volumes: Vec::new(),
        };
        let linking = Linking {
            lit: vec![Some(members(&[2])), None],
            shadow: vec![Some(members(&[1])), None],
            runs: vec![run(2, 3, &[2, 0]), run(7, 1, &[1])],
            sets: 3,
        };
        let sets: Vec<u32> = [
            (0, 0),
            (2, 0),
            (4, 0),
            (4, 1),
            (5, 0),
            (7, 0),
            (7, 1),
            (9, 0),
        ]
        .iter()
        .map(|&(i, p)| linking.receiver(i, p).0)
        .collect();
        assert_eq!(sets, [0, 2, 2, 0, 0, 1, 0, 0]);
        let (two, one) = (Receiver(2), Receiver(1));
        assert!(linking.lights(0, two) && !linking.lights(0, one));
        assert!(!linking.lights(0, Receiver::UNNAMED) && linking.lights(0, Receiver::CAMERA));
        assert!(linking.lights(1, one) && linking.lights(1, Receiver::UNNAMED));
        assert!(linking.casts_shadow(0, one) && !linking.casts_shadow(0, two));
        assert!(linking.shadow_linked(0) && !linking.shadow_linked(1));
    }
}
