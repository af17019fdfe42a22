//! What the study reports per scene: a Markdown summary line per method,
//! log-log charts of relMSE against time and spp, and with peers
//! `equal_time.md`, our relMSE over each peer's at the peer's render times.

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

/// The slope of ln median relMSE against ln spp over one method's budgets:
/// -1 for plain Monte Carlo, lower for QMC, flatter where the reference's
/// noise or a bias dominates.
fn spp_slope(summaries: &[Summary]) -> f64 {
    let points: Vec<(f64, f64)> = summaries
        .iter()
        .map(|s| (f64::from(s.spp), s.relmse))
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
            spp_slope(list)
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

/// Writes `equal_time.md`: per scene, peer and budget, our relMSE over the
/// peer's at the peer's render time (below 1: we are more accurate in the
/// same time), against our reference and against each one's own.
pub(crate) fn write_equal_time(out: &Path, machine: &str, rows: &[EqualTime]) -> Result<()> {
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
    let path = out.join("equal_time.md");
    write_text(&path, &text)?;
    println!("{text}\nWrote {}", path.display());
    Ok(())
}
