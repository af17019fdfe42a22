//! Validation of the per-instance primvars (`Instances::primvars`).

use super::{Checker, SceneError};

impl Checker<'_> {
    /// Each run: values of width 1 to 4, finite, inside the instances, runs
    /// of one name increasing and not overlapping.
    pub(super) fn instance_primvars(&self) -> Result<(), SceneError> {
        let inst = &self.manifest.instances;
        for (name, runs) in &inst.primvars {
            let mut next = 0u64;
            for (i, run) in runs.iter().enumerate() {
                let field = format!("instances.primvars.{name}[{i}]");
                let values = self.array_of_width(&format!("{field}.values"), &run.values, 1..=4)?;
                self.finite(&format!("{field}.values"), values)?;
                let end = run.first.checked_add(run.values.count);
                if run.first < next || end.is_none_or(|end| end > inst.count) {
                    return Err(self.invalid(
                        &field,
                        format!(
                            "instances {}..{} overlap an earlier run or exceed the {} instances",
                            run.first,
                            end.map_or("overflow".into(), |e| e.to_string()),
                            inst.count
                        ),
                    ));
                }
                next = end.unwrap_or(u64::MAX);
            }
        }
        Ok(())
    }
}
