//! A job's frames: its one frame, or each frame of `--frames` in turn, each
//! exported from the USD stage at its time code and written where the
//! output's frame token says.

use super::frame::render_frame;
use super::{frame_output, has_frame_number, JobControl, JobError, RenderJob};

/// Runs `job`: renders its frame, or each of its frames in turn, telling
/// `control` as each is done; stops at the first that fails or is stopped.
pub fn render(job: &RenderJob, control: &JobControl) -> Result<(), JobError> {
    let Some(range) = job.frames else {
        (control.done)(&render_frame(job, false, control)?);
        return Ok(());
    };
    let frames: Vec<i64> = range.frames().collect();
    if frames.len() > 1 && job.output.as_ref().is_some_and(|o| !has_frame_number(o)) {
        return Err(JobError::Refused(
            "--frames: -o has no frame token for the frame number (e.g. out/shot.####.exr)".into(),
        ));
    }
    if !crate::scene::is_usd(&job.scene) {
        return Err(JobError::Refused(format!(
            "--frames needs a USD scene; {} is exported",
            job.scene.display()
        )));
    }
    for (i, &frame) in frames.iter().enumerate() {
        log::info!("frame {frame} ({} of {})", i + 1, frames.len());
        let one = RenderJob {
            frame: Some(frame as f64),
            frames: None,
            output: job.output.as_ref().map(|o| frame_output(o, Some(frame))),
            ..job.clone()
        };
        (control.done)(&render_frame(&one, frames.len() > 1, control)?);
    }
    Ok(())
}
