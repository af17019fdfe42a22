//! `cirrus merge`: the parts of one frame (film-state files written by
//! `cirrus render --tile/--crop/--sample-range -o PART.film`) checked to fit
//! together and added into the frame's EXR.

use std::path::{Path, PathBuf};
use std::time::Duration;

use super::FarmError;
use crate::film::{Film, Tile};
use crate::image::Compression;
use crate::integrator::{RayCounts, RenderStats};
use crate::job::{prepare_folder, read_snapshot, OutputFiles, SnapshotHeader};
use crate::output::{preview_path, write_film, write_film_preview, AovFiles};
use crate::volumes::estimators::TrackingStats;

/// One part read back.
struct Part {
    path: PathBuf,
    header: SnapshotHeader,
    film: Film,
}

impl Part {
    /// The pixels of its frame: the data window it records, else the image.
    fn frame(&self) -> Tile {
        (self.header.identity.part).frame_window(self.film.resolution)
    }
}

/// What [`merge`] wrote.
pub struct Merged {
    /// How many parts were added.
    pub parts: usize,
    /// Their rendering time added up, seconds.
    pub seconds: f64,
    /// The PNG preview written beside the EXR.
    pub preview: PathBuf,
}

/// `cirrus merge`: checks that the film-state files `paths` are parts of one
/// frame (same scene and settings), finished, and cover every pixel's
/// samples exactly once, listing every problem; then adds them and writes
/// the frame to `output` (overwriting it atomically) with its PNG preview.
/// A rescued film state of a whole frame (see `job/rescue.rs`) is such a part
/// alone; merging the output's own checkpoint finishes that render.
pub fn merge(
    paths: &[PathBuf],
    output: &Path,
    aov_files: AovFiles,
    compression: Compression,
) -> Result<Merged, FarmError> {
    let mut parts = Vec::new();
    for path in paths {
        let (header, film) = read_snapshot(path)?;
        parts.push(Part {
            path: path.clone(),
            header,
            film,
        });
    }
    let problems = problems(&parts);
    if !problems.is_empty() {
        return Err(FarmError::Refused(format!(
            "cannot merge these {} parts:\n  {}",
            parts.len(),
            problems.join("\n  ")
        )));
    }
    let first = &parts[0];
    let files = OutputFiles::new(output, aov_files, first.film.aov_set());
    let layers = (first.header.identity.exr.layers())
        .map_err(|e| FarmError::Refused(format!("{}: {e}", first.path.display())))?;
    prepare_folder(output)?;
    let aovs = first.film.aov_set().clone();
    let mut frame = Film::cropped(first.film.resolution, first.frame(), aovs);
    let mut stats = RenderStats {
        samples_per_pixel: first.header.identity.part.frame_spp,
        elapsed: Duration::ZERO,
        rays: RayCounts::default(),
        non_finite: Default::default(),
        tracking: TrackingStats::default(),
        complete: true,
    };
    for part in &parts {
        frame.add_part(&part.film);
        let p = &part.header.progress;
        stats.elapsed += Duration::from_secs_f64(p.seconds);
        stats.rays.add(&p.rays);
        stats.tracking.merge(&p.tracking);
    }
    stats.non_finite = frame.non_finite;
    let mut header = first.header.identity.exr.clone();
    for part in &parts[1..] {
        header.add_names_of(&part.header.identity.exr);
    }
    write_film(
        output,
        aov_files,
        &frame,
        &header,
        &stats,
        compression,
        &layers,
    )?;
    let preview = preview_path(output);
    write_film_preview(&preview, &frame)?;
    if paths.contains(&files.checkpoint) {
        files.finish()?;
    }
    Ok(Merged {
        parts: parts.len(),
        seconds: stats.elapsed.as_secs_f64(),
        preview,
    })
}

/// Everything that stops `parts` from making one frame, one line each.
fn problems(parts: &[Part]) -> Vec<String> {
    let mut problems = Vec::new();
    let first = &parts[0];
    let name = |p: &Part| p.path.display().to_string();
    for part in &parts[1..] {
        let (a, b) = (&first.header.identity, &part.header.identity);
        problems.extend(
            a.fingerprint
                .differences(&b.fingerprint, [&name(first), &name(part)]),
        );
        let frame = |p: &Part| (p.header.identity.part.frame_spp, p.film.resolution);
        if frame(part) != frame(first) || b.part.data_window != a.part.data_window {
            problems.push(format!(
                "{} is of another frame than {}",
                name(part),
                name(first)
            ));
        }
    }
    let frame = first.frame();
    for part in parts {
        if !inside(part.film.window, frame) {
            problems.push(format!(
                "{} covers pixels outside its frame's data window",
                name(part)
            ));
        }
        let p = &part.header.progress;
        if p.next_sample() != part.header.identity.part.samples.end {
            problems.push(format!(
                "{} is unfinished ({} of samples {:?}); resume it",
                name(part),
                p.samples_per_pixel(),
                part.header.identity.part.samples
            ));
        }
    }
    for (i, a) in parts.iter().enumerate() {
        for b in &parts[i + 1..] {
            let (sa, sb) = (
                &a.header.identity.part.samples,
                &b.header.identity.part.samples,
            );
            if overlap(a.film.window, b.film.window) && sa.start < sb.end && sb.start < sa.end {
                problems.push(format!(
                    "{} and {} overlap (both take samples {}..{} of some pixels)",
                    name(a),
                    name(b),
                    sa.start.max(sb.start),
                    sa.end.min(sb.end)
                ));
            }
        }
    }
    if problems.is_empty() {
        problems.extend(missing(parts));
    }
    problems
}

/// Whether every pixel of `a` lies in `b`.
fn inside(a: Tile, b: Tile) -> bool {
    let (a1, b1) = (a.origin + a.size, b.origin + b.size);
    a.origin.cmpge(b.origin).all() && a1.cmple(b1).all()
}

/// Whether two windows share a pixel.
fn overlap(a: Tile, b: Tile) -> bool {
    let (a1, b1) = (a.origin + a.size, b.origin + b.size);
    a.origin.x < b1.x && b.origin.x < a1.x && a.origin.y < b1.y && b.origin.y < a1.y
}

/// Pixels whose samples the (non-overlapping) parts do not all cover: the
/// count and the first such pixel.
fn missing(parts: &[Part]) -> Option<String> {
    let first = &parts[0];
    let frame = first.frame();
    let (o, r) = (frame.origin, frame.size);
    let spp = first.header.identity.part.frame_spp;
    let mut covered = vec![0u32; r.x as usize * r.y as usize];
    for part in parts {
        let w = part.film.window;
        let n = part.header.identity.part.samples.len() as u32;
        for y in w.origin.y - o.y..w.origin.y - o.y + w.size.y {
            let row = y as usize * r.x as usize;
            for x in w.origin.x - o.x..w.origin.x - o.x + w.size.x {
                covered[row + x as usize] += n;
            }
        }
    }
    let short: Vec<usize> = (0..covered.len()).filter(|&i| covered[i] < spp).collect();
    let i = *short.first()?;
    Some(format!(
        "{} pixels lack samples; the first, ({}, {}), has {} of {spp}: a part is missing",
        short.len(),
        o.x as usize + i % r.x as usize,
        o.y as usize + i / r.x as usize,
        covered[i]
    ))
}
