//! `cirrus info` for a VDB file: its grid table, one row per grid, as plain
//! text.

use super::{GridInfo, VdbFile};

/// The grid table of a VDB file: one row per grid, in file order.
pub fn grid_table(vdb: &VdbFile) -> String {
    let mut out = format!("{}: {} grid(s)\n", vdb.path().display(), vdb.grids().len());
    for (i, g) in vdb.grids().iter().enumerate() {
        out += &format!("\n[{i}] {}  ({}, {})\n", g.name, g.value_type, g.grid_class);
        out += &format!("    voxel size      {}\n", vec3(g.voxel_size.to_array()));
        out += &format!("    active voxels   {}\n", g.active_voxel_count);
        out += &bounds_line(g);
        match g.world_from_index {
            Some(m) => {
                let m = glam::DMat4::from(m);
                out += "    world_from_index\n";
                for r in 0..4 {
                    out += &format!("      {}\n", vec3_4(m.row(r).to_array()));
                }
            }
            None => {
                out += "    transform       non-affine (frustum): not supported for rendering\n"
            }
        }
    }
    out
}

fn bounds_line(g: &GridInfo) -> String {
    if g.active_voxel_count == 0 {
        return "    index bounds    empty\n".to_owned();
    }
    let d = g.dims();
    format!(
        "    index bounds    [{}, {}, {}] .. [{}, {}, {}]  ({} x {} x {})\n",
        g.index_min.x,
        g.index_min.y,
        g.index_min.z,
        g.index_max.x,
        g.index_max.y,
        g.index_max.z,
        d.x,
        d.y,
        d.z
    )
}

fn vec3(v: [f64; 3]) -> String {
    format!("{:.6} {:.6} {:.6}", v[0], v[1], v[2])
}

fn vec3_4(v: [f64; 4]) -> String {
    format!(
        "{:>12.6} {:>12.6} {:>12.6} {:>12.6}",
        v[0], v[1], v[2], v[3]
    )
}
