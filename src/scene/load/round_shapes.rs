//! Validation of the points and curves records (`Manifest::points`,
//! `Manifest::curves`) and of the prototype parts that place them.

use std::collections::BTreeMap;

use super::{Checker, SceneError};
use crate::scene::format::{Array, Curves, Points, PointsMotion, NO_MATERIAL};

impl Checker<'_> {
    /// Every points and curves record, and every prototype's parts placing them.
    pub(super) fn round_shapes(&self) -> Result<(), SceneError> {
        let m = self.manifest;
        for (i, points) in m.points.iter().enumerate() {
            self.points(i, points)?;
        }
        for (i, curves) in m.curves.iter().enumerate() {
            self.curves(i, curves)?;
        }
        for (i, proto) in m.prototypes.iter().enumerate() {
            let points = proto.points.iter().map(|p| (p.points, &p.transform));
            self.parts(i, ("points", "points"), points, m.points.len())?;
            let curves = proto.curves.iter().map(|p| (p.curves, &p.transform));
            self.parts(i, ("curves", "curves"), curves, m.curves.len())?;
        }
        Ok(())
    }

    /// Finite centres; one width or one per point, finite and not negative.
    fn points(&self, i: usize, points: &Points) -> Result<(), SceneError> {
        let field = |name: &str| format!("points[{i}].{name}");
        let centres = self.array(&field("points"), &points.points)?;
        self.finite(&field("points"), bytemuck::cast_slice(centres))?;
        let widths = self.array(&field("widths"), &points.widths)?;
        if widths.len() != 1 {
            self.count(&field("widths"), widths.len(), centres.len(), "point")?;
        }
        self.widths(&field("widths"), widths)?;
        self.shape_material(&field("material"), points.material)?;
        if let Some(motion) = &points.motion {
            self.points_motion(&field("motion"), motion, centres.len())?;
        }
        self.shape_primvars(&field("primvars"), &points.primvars, centres.len(), "point")
    }

    /// Moving points' or deforming curves' keys (`field` is `points[i].motion`
    /// or `curves[i].motion`): key times, a finite centre (and width, when
    /// keyed) for every point or vertex at every key.
    fn points_motion(
        &self,
        field: &str,
        motion: &PointsMotion,
        points: usize,
    ) -> Result<(), SceneError> {
        let want = self.keyed_points(field, &motion.times, &motion.points, points)?;
        if let Some(widths) = &motion.widths {
            let field = format!("{field}.widths");
            let widths = self.array(&field, widths)?;
            self.count(&field, widths.len(), want, "point and key time")?;
            self.widths(&field, widths)?;
        }
        Ok(())
    }

    /// Finite vertices, one width per vertex, curves of 2 or more vertices
    /// covering every vertex; keys (when deforming) for every vertex.
    fn curves(&self, i: usize, curves: &Curves) -> Result<(), SceneError> {
        let field = |name: &str| format!("curves[{i}].{name}");
        let vertices = self.array(&field("points"), &curves.points)?;
        self.finite(&field("points"), bytemuck::cast_slice(vertices))?;
        let widths = self.array(&field("widths"), &curves.widths)?;
        self.count(&field("widths"), widths.len(), vertices.len(), "vertex")?;
        self.widths(&field("widths"), widths)?;
        let counts = self.array(&field("vertex_counts"), &curves.vertex_counts)?;
        if let Some(at) = counts.iter().position(|&n| n < 2) {
            let message = format!("curve {at} has {} vertices, expected 2 or more", counts[at]);
            return Err(self.invalid(&field("vertex_counts"), message));
        }
        let total: u64 = counts.iter().map(|&n| u64::from(n)).sum();
        if total != vertices.len() as u64 {
            let message = format!(
                "sum {total}, expected the vertex count ({})",
                vertices.len()
            );
            return Err(self.invalid(&field("vertex_counts"), message));
        }
        self.shape_material(&field("material"), curves.material)?;
        if let Some(motion) = &curves.motion {
            self.points_motion(&field("motion"), motion, vertices.len())?;
        }
        self.shape_primvars(
            &field("primvars"),
            &curves.primvars,
            vertices.len(),
            "vertex",
        )
    }

    /// Widths (diameters): finite and not negative.
    fn widths(&self, field: &str, widths: &[f32]) -> Result<(), SceneError> {
        self.finite(field, widths)?;
        match widths.iter().position(|&w| w < 0.0) {
            None => Ok(()),
            Some(at) => {
                Err(self.invalid(field, format!("width {} at {at} is negative", widths[at])))
            }
        }
    }

    fn shape_material(&self, field: &str, material: u32) -> Result<(), SceneError> {
        let len = self.manifest.materials.len();
        let indices = std::iter::once(material);
        self.indices(field, indices, len, "materials", Some(NO_MATERIAL))
    }

    /// Primvars of 1 to 4 finite floats, one per `of`, `len` of them.
    fn shape_primvars(
        &self,
        field: &str,
        primvars: &BTreeMap<String, Array<f32>>,
        len: usize,
        of: &str,
    ) -> Result<(), SceneError> {
        for (name, primvar) in primvars {
            let field = format!("{field}.{name}");
            let values = self.array_of_width(&field, primvar, 1..=4)?;
            self.count(&field, primvar.count as usize, len, of)?;
            self.finite(&field, values)?;
        }
        Ok(())
    }
}
