//! Pieces of the Markdown tables the studies print: error columns per time
//! budget, their cells, and option values by their command-line names.

use std::fmt::Write as _;

use super::metrics::ErrorMetric;

/// The Markdown header cells and rule cells of one error column per time:
/// `" MSE @ 1 s |"` and `"---:|"` each.
pub(crate) fn error_columns(metric: ErrorMetric, times: &[f64]) -> (String, String) {
    let mut header = String::new();
    for t in times {
        let _ = write!(header, " {} @ {t} s |", metric.name());
    }
    (header, "---:|".repeat(times.len()))
}

/// Prints a Markdown table's header: the `leading` header cells and rule
/// cells (each `| ... |`), then one `metric` column per time of `times`.
pub(crate) fn print_error_header(leading: (&str, &str), metric: ErrorMetric, times: &[f64]) {
    let (errors_header, errors_rule) = error_columns(metric, times);
    println!("{}{errors_header}\n{}{errors_rule}", leading.0, leading.1);
}

/// The Markdown cells of `errors`, one per time of [`error_columns`].
pub(crate) fn error_cells(errors: &[f64]) -> String {
    errors.iter().map(|e| format!(" {e:.3e} |")).collect()
}
