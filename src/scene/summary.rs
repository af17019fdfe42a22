//! `cirrus info` for a scene: counts of everything it holds, one line per
//! kind, as plain text.

use std::collections::BTreeMap;

use super::Scene;

/// Per link set (exporter/FORMAT.md, "Linking"), how many placed parts
/// (surface and volume parts of every instance) it holds.
fn placed_parts_by_link_set(scene: &Scene) -> Vec<u64> {
    let m = &scene.manifest;
    let parts_of = |p: &super::Prototype| {
        (p.meshes.len() + p.points.len() + p.curves.len() + p.volumes.len()) as u64
    };
    let total: u64 = scene
        .view(&m.instances.prototype)
        .iter()
        .map(|&p| parts_of(&m.prototypes[p as usize]))
        .sum();
    let mut sets = vec![total];
    for run in &m.instances.links {
        for &set in run.parts.iter().chain(&run.volumes) {
            if sets.len() <= set as usize {
                sets.resize(set as usize + 1, 0);
            }
            sets[set as usize] += run.count;
            sets[0] = sets[0].saturating_sub(run.count);
        }
    }
    sets
}

/// Counts of everything a scene holds, one line per kind.
pub fn summary(scene: &Scene) -> String {
    let m = &scene.manifest;
    let mut out = format!(
        "{}: scene from {}",
        scene.dir.display(),
        m.source.path.display()
    );
    if let Some(t) = m.source.time_code {
        out += &format!(" at time {t}");
    }
    out += "\n";
    let mut line = |label: &str, value: String| out += &format!("  {label:<12} {value}\n");

    // Triangles per prototype, then per instance through its prototype.
    let proto_triangles: Vec<u64> = m
        .prototypes
        .iter()
        .map(|p| {
            p.meshes
                .iter()
                .map(|part| m.meshes[part.mesh as usize].triangles.count)
                .sum()
        })
        .collect();
    let instanced: u64 = scene
        .view(&m.instances.prototype)
        .iter()
        .map(|&p| proto_triangles[p as usize])
        .sum();
    let unique: u64 = m.meshes.iter().map(|mesh| mesh.triangles.count).sum();

    line("prototypes", m.prototypes.len().to_string());
    line(
        "instances",
        format!(
            "{} from {} source prim(s)",
            m.instances.count,
            m.instances.instance_sources.len()
        ),
    );
    line("meshes", m.meshes.len().to_string());
    line(
        "triangles",
        format!("{unique} unique, {instanced} instanced"),
    );
    let points: u64 = m.points.iter().map(|p| p.points.count).sum();
    line("points", format!("{points} in {} prim(s)", m.points.len()));
    let pieces: u64 = m
        .curves
        .iter()
        .map(|c| c.points.count - c.vertex_counts.count)
        .sum();
    let curves: u64 = m.curves.iter().map(|c| c.vertex_counts.count).sum();
    line(
        "curves",
        format!(
            "{curves} in {} prim(s), {pieces} tube pieces",
            m.curves.len()
        ),
    );
    line(
        "lights",
        counted(m.lights.len(), m.lights.iter().map(|l| l.shape.type_name())),
    );
    let in_sets = placed_parts_by_link_set(scene);
    let parts = |sets: &[u32]| -> u64 {
        sets.iter()
            .map(|&s| in_sets.get(s as usize).copied().unwrap_or(0))
            .sum()
    };
    for l in &m.lights {
        let (lit, shadow) = (&l.links.light_link, &l.links.shadow_link);
        if lit.is_none() && shadow.is_none() {
            continue;
        }
        let said = |sets: &Option<Vec<u32>>, what: &str| {
            sets.as_deref().map(|s| {
                format!(
                    "{what} {} placed part(s) in {} link set(s)",
                    parts(s),
                    s.len()
                )
            })
        };
        let linked = [said(lit, "lights"), said(shadow, "shadow cast by")];
        let linked: Vec<String> = linked.into_iter().flatten().collect();
        line("", format!("{}: {}", l.path, linked.join("; ")));
    }
    let skipped: Vec<&super::Material> = m.skipped_looks().collect();
    line(
        "materials",
        format!(
            "{}; {} fell back, {} skipped a richer look",
            counted(m.materials.len(), m.material_models()),
            m.fallback_count(),
            skipped.len()
        ),
    );
    for mat in skipped {
        line("", format!("{}: {}", mat.path, mat.skipped.join("; ")));
    }
    line("subdivided", scene.subdivision.to_string());
    line("textures", m.textures.len().to_string());
    line("volumes", m.volumes.len().to_string());
    for v in &m.volumes {
        let fields: Vec<String> = v
            .fields
            .iter()
            .map(|(name, f)| format!("{name} = {}:{}[{}]", f.file.display(), f.grid, f.index))
            .collect();
        line("", format!("{}: {}", v.path, fields.join(", ")));
    }
    let c = &m.camera;
    line(
        "camera",
        format!(
            "{} ({}, focal length {}, aperture {} x {})",
            c.path.as_deref().unwrap_or("default, framing the bounds"),
            format!("{:?}", c.projection).to_lowercase(),
            c.focal_length,
            c.horizontal_aperture,
            c.vertical_aperture
        ),
    );
    line(
        "resolution",
        m.render
            .resolution
            .map_or("not set".to_owned(), |[w, h]| format!("{w} x {h}")),
    );
    line(
        "bounds",
        format!(
            "[{}] .. [{}] ({} m per unit, {:?} up)",
            join(m.bounds.min),
            join(m.bounds.max),
            m.stage.meters_per_unit,
            m.stage.up_axis
        ),
    );
    let bytes = scene.array_bytes();
    let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
    line(
        "arrays",
        format!(
            "meshes {:.2} MiB, instances {:.2} MiB",
            mib(bytes.meshes),
            mib(bytes.instances)
        ),
    );
    line("warnings", m.warnings.len().to_string());
    let kinds = |counts: &BTreeMap<String, u64>| match counts.is_empty() {
        true => "none".to_owned(),
        false => (counts.iter().map(|(kind, n)| format!("{n} {kind}")))
            .collect::<Vec<_>>()
            .join(", "),
    };
    let u = &m.unrendered;
    line(
        "unrendered",
        format!(
            "not rendered: {}; approximated: {}",
            kinds(&u.not_rendered),
            kinds(&u.approximated)
        ),
    );
    out
}

/// "3 (1 distant, 2 rect)": a total and its breakdown by name.
fn counted<'a>(total: usize, names: impl Iterator<Item = &'a str>) -> String {
    let mut by_name = BTreeMap::<&str, usize>::new();
    for name in names {
        *by_name.entry(name).or_default() += 1;
    }
    if by_name.is_empty() {
        return total.to_string();
    }
    let parts: Vec<String> = by_name.iter().map(|(n, c)| format!("{c} {n}")).collect();
    format!("{total} ({})", parts.join(", "))
}

fn join(v: [f32; 3]) -> String {
    format!("{} {} {}", v[0], v[1], v[2])
}
