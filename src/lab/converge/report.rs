//! What the study reports per scene: a Markdown summary line per method,
//! log-log charts of relMSE against time and spp, and with peers
//! `equal_time.md`, our relMSE over each peer's at the peer's render times
//! and the seconds each renderer takes to reach relMSE 1e-3 and 1e-4.

use std::path::Path;

use super::method::{Method, Series};
use super::rows::Summary;
use crate::lab::chart::{write_chart, SPP_AXIS, TIME_AXIS};
use crate::lab::equal_time::error_at_time;
use crate::lab::files::write_text;
use crate::lab::metrics::ErrorMetric;
use crate::lab::peers::Peer;
use crate::lab::stats::log_log_slope;
use crate::lab::Result;

/// The slope of ln median `relmse` (a relMSE of [`Summary`]) against ln spp
/// over one method's budgets: -1 for plain Monte Carlo, lower for QMC,
/// flatter where the reference's noise or a bias dominates.
fn spp_slope(summaries: &[Summary], relmse: fn(&Summary) -> f64) -> f64 {
    let points: Vec<(f64, f64)> = summaries
        .iter()
        .map(|s| (f64::from(s.spp), relmse(s)))
        .collect();
    log_log_slope(&points)
}

/// The summaries of each method of one scene (its budgets, in the order
/// rendered).
fn by_method(summaries: &[Summary]) -> impl Iterator<Item = &[Summary]> {
    summaries.chunk_by(|a, b| a.method == b.method)
}

/// One Markdown line per method: its largest budget's medians, the bias
/// interval there, and the relMSE slope over all budgets.
pub(crate) fn print_summary(name: &str, summaries: &[Summary]) {
    println!("### {name}\n");
    println!(
        "| method | flag | spp | seconds | relMSE | RMSE | bias (95% CI) | relMSE slope vs spp |"
    );
    println!("|---|---|---:|---:|---:|---:|---|---:|");
    for list in by_method(summaries) {
        let last = list.last().expect("a method has one budget at least");
        let method = last.method;
        println!(
            "| {} | {} | {} | {:.3} | {:.3e} | {:.3e} | {:.2e} ± {:.2e} | {:.2} |",
            method.name(),
            method.flag(),
            last.spp,
            last.seconds,
            last.relmse,
            last.rmse,
            last.bias.mean,
            last.bias.half_width,
            spp_slope(list, |s| s.relmse)
        );
    }
    println!();
}

/// The charts of one scene, median relMSE over the seeds per series:
/// `<scene>-relmse-time.svg` (against median seconds) and
/// `<scene>-relmse-spp.svg`, both against our reference; with peers also
/// `<scene>-relmse-own-time.svg`, each renderer against its own reference.
pub(crate) fn write_charts(out: &Path, name: &str, summaries: &[Summary]) -> Result<()> {
    let curves = |x: fn(&Summary) -> f64, y: fn(&Summary) -> f64| {
        by_method(summaries)
            .map(|list| {
                let points = list.iter().map(|s| (x(s), y(s))).collect();
                (list[0].method.name(), points)
            })
            .collect::<Vec<(String, Vec<(f64, f64)>)>>()
    };
    let seconds = |s: &Summary| s.seconds;
    let relmse = |s: &Summary| s.relmse;
    let mut charts = vec![
        ("time", name.to_owned(), &TIME_AXIS, curves(seconds, relmse)),
        (
            "spp",
            name.to_owned(),
            &SPP_AXIS,
            curves(|s| f64::from(s.spp), relmse),
        ),
    ];
    if summaries
        .iter()
        .any(|s| matches!(s.method, Series::Peer(_)))
    {
        let title = format!("{name}, each renderer against its own reference");
        charts.push((
            "own-time",
            title,
            &TIME_AXIS,
            curves(seconds, |s| s.relmse_own),
        ));
    }
    for (suffix, title, axis, curves) in charts {
        let path = out.join(format!("{name}-relmse-{suffix}.svg"));
        write_chart(&path, &title, axis, ErrorMetric::RelMse, &curves)?;
        println!("Chart: {}", path.display());
    }
    println!();
    Ok(())
}

/// One peer budget of `equal_time.md`: the peer's medians and our default
/// method's at the same render time.
pub(crate) struct EqualTime {
    scene: String,
    peer: Peer,
    spp: u32,
    /// The peer's median render seconds.
    seconds: f64,
    /// The peer's median relMSE against our reference and against its own.
    peer_relmse: f64,
    peer_relmse_own: f64,
    /// Our default method's median relMSE at `seconds` (log-log in time).
    ours_relmse: f64,
    /// Whether `seconds` lies within our default method's measured times
    /// (else `ours_relmse` is extrapolated from the end segment).
    within: bool,
}

/// The equal-time comparisons of one scene: for each peer budget, our
/// default method's median relMSE read off at the peer's median time with
/// [`error_at_time`] (our error is against our reference, which is also our
/// own). Empty without peers or without the default method.
pub(crate) fn equal_time_rows(summaries: &[Summary]) -> Vec<EqualTime> {
    let ours: Vec<(f64, f64)> = summaries
        .iter()
        .filter(|s| s.method == Series::Ours(Method::Default))
        .map(|s| (s.seconds, s.relmse))
        .collect();
    let Some(((first, _), (last, _))) = ours.first().zip(ours.last()) else {
        return Vec::new();
    };
    summaries
        .iter()
        .filter_map(|s| match s.method {
            Series::Peer(peer) => Some(EqualTime {
                scene: s.scene.clone(),
                peer,
                spp: s.spp,
                seconds: s.seconds,
                peer_relmse: s.relmse,
                peer_relmse_own: s.relmse_own,
                ours_relmse: error_at_time(&ours, s.seconds),
                within: (*first..=*last).contains(&s.seconds),
            }),
            Series::Ours(_) => None,
        })
        .collect()
}

/// The relMSE levels of the time-to-error table (issue 20).
const ERROR_LEVELS: [f64; 2] = [1e-3, 1e-4];

/// One renderer on one scene in the time-to-error table.
pub(crate) struct TimeToError {
    scene: String,
    series: Series,
    /// Seconds to reach each of [`ERROR_LEVELS`], and whether measured
    /// (false: extrapolated); None when the curve does not fall.
    seconds: [Option<(f64, bool)>; 2],
    /// Slope of ln relMSE (own reference) against ln spp over all budgets.
    slope: f64,
}

/// Seconds for a renderer's budgets, (median seconds, median relMSE) in
/// budget order, to reach `level`: interpolated log-log in time between the
/// first budget at or below it and the one before (the first budget's time
/// when that one is already below); past the largest budget, extrapolated
/// (flagged false) from it along `spp_slope`, the relMSE slope against spp,
/// at its seconds per sample: t = t_last (level / e_last)^(1 / spp_slope).
/// Times measured under load are too noisy for a slope in time. None when
/// `spp_slope` is not negative.
fn seconds_to_reach(points: &[(f64, f64)], spp_slope: f64, level: f64) -> Option<(f64, bool)> {
    match points.iter().position(|p| p.1 <= level) {
        Some(0) => Some((points[0].0, true)),
        Some(i) => {
            let ((t0, e0), (t1, e1)) = (points[i - 1], points[i]);
            let f = (level / e0).ln() / (e1 / e0).ln();
            Some(((t0.ln() + f * (t1 / t0).ln()).exp(), true))
        }
        None => {
            let &(t, e) = points.last()?;
            (spp_slope < 0.0).then(|| (t * (level / e).powf(1.0 / spp_slope), false))
        }
    }
}

/// The time-to-error rows of one scene: our default method and each peer,
/// each against its own reference (ours is our reference), so that every
/// renderer's error is its noise alone.
pub(crate) fn time_to_error_rows(summaries: &[Summary]) -> Vec<TimeToError> {
    by_method(summaries)
        .filter(|list| {
            matches!(
                list[0].method,
                Series::Ours(Method::Default) | Series::Peer(_)
            )
        })
        .map(|list| {
            let points: Vec<(f64, f64)> = list.iter().map(|s| (s.seconds, s.relmse_own)).collect();
            let slope = spp_slope(list, |s| s.relmse_own);
            TimeToError {
                scene: list[0].scene.clone(),
                series: list[0].method,
                seconds: ERROR_LEVELS.map(|level| seconds_to_reach(&points, slope, level)),
                slope,
            }
        })
        .collect()
}

/// The time-to-error table in Markdown.
fn time_to_error_table(rows: &[TimeToError]) -> String {
    let mut text = String::from(
        "## Seconds to reach relMSE 1e-3 and 1e-4\n\n\
         Each renderer against its own reference: median render seconds (threads as \
         above) interpolated log-log between budgets; `*` = extrapolated from the largest \
         budget at its seconds per sample along the relMSE slope against spp (last column).\n\n\
         | scene | renderer | seconds to 1e-3 | seconds to 1e-4 | relMSE slope vs spp |\n\
         |---|---|---:|---:|---:|\n",
    );
    for r in rows {
        let cell = |c: Option<(f64, bool)>| {
            c.map_or("-".to_owned(), |(t, measured)| {
                format!("{t:.3}{}", if measured { "" } else { "*" })
            })
        };
        text.push_str(&format!(
            "| {} | {} | {} | {} | {:.2} |\n",
            r.scene,
            r.series.name(),
            cell(r.seconds[0]),
            cell(r.seconds[1]),
            r.slope
        ));
    }
    text
}

/// Writes `equal_time.md`: per scene, peer and budget, our relMSE over the
/// peer's at the peer's render time (below 1: we are more accurate in the
/// same time), against our reference and against each one's own; then the
/// time-to-error table.
pub(crate) fn write_equal_time(
    out: &Path,
    machine: &str,
    rows: &[EqualTime],
    times: &[TimeToError],
) -> Result<()> {
    let mut text = format!(
        "# Equal-time relMSE, Cirrus (default method) against peers\n\n{machine}\n\n\
         At each peer budget, Cirrus' median relMSE at the peer's median render time (read \
         off Cirrus' curve, log-log in time; `*` = extrapolated past Cirrus' measured times) \
         over the peer's. Below 1: Cirrus is more accurate in the same time. Against our \
         reference, and against each renderer's own reference.\n\n\
         | scene | peer | peer spp | seconds | peer relMSE | Cirrus relMSE | ratio Cirrus/peer | peer relMSE (own ref) | ratio (own refs) |\n\
         |---|---|---:|---:|---:|---:|---:|---:|---:|\n"
    );
    for r in rows {
        let mark = if r.within { "" } else { "*" };
        text.push_str(&format!(
            "| {} | {} | {} | {:.3} | {:.3e} | {:.3e}{mark} | {:.3}{mark} | {:.3e} | {:.3}{mark} |\n",
            r.scene,
            r.peer,
            r.spp,
            r.seconds,
            r.peer_relmse,
            r.ours_relmse,
            r.ours_relmse / r.peer_relmse,
            r.peer_relmse_own,
            r.ours_relmse / r.peer_relmse_own
        ));
    }
    text.push('\n');
    text.push_str(&time_to_error_table(times));
    let path = out.join("equal_time.md");
    write_text(&path, &text)?;
    println!("{text}\nWrote {}", path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_to_reach_interpolates_and_extrapolates_power_laws() {
        // relMSE = 1e-2 / t: 1e-3 at 10 s (between 8 and 16), 1e-4 at 100 s.
        let points: Vec<(f64, f64)> = [1.0, 2.0, 4.0, 8.0, 16.0].map(|t| (t, 1e-2 / t)).to_vec();
        let (t, measured) = seconds_to_reach(&points, -1.0, 1e-3).unwrap();
        assert!(measured && (t - 10.0).abs() < 1e-9, "{t}");
        let (t, measured) = seconds_to_reach(&points, -1.0, 1e-4).unwrap();
        assert!(!measured && (t - 100.0).abs() < 1e-6, "{t}");
        // Slower than 1/spp: 1e-4 is 6.25e-4 / 1e-4 = 6.25 = (t / 16)^0.5 away.
        let (t, _) = seconds_to_reach(&points, -0.5, 1e-4).unwrap();
        assert!((t - 16.0 * 6.25f64.powi(2)).abs() < 1e-6, "{t}");
        assert_eq!(seconds_to_reach(&points, -1.0, 1.0), Some((1.0, true)));
        // A flat curve never gets there.
        assert_eq!(seconds_to_reach(&[(1.0, 1.0)], 0.0, 1e-3), None);
    }
}
