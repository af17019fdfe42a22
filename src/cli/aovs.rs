//! `cirrus aovs OUT.exr [-o SHEET.png]`: a contact sheet of every layer of an
//! EXR (beauty, AOVs, Cryptomattes) and the list of its layers.

use std::path::PathBuf;

use anyhow::Result;

use cirrus::image::read_exr;
use cirrus::output::{contact_sheet_path, write_contact_sheet};

/// `cirrus aovs` arguments.
#[derive(clap::Args, Debug)]
pub struct AovsArgs {
    /// The EXR to show.
    exr: PathBuf,
    /// The PNG to write [default: beside the EXR, NAME.aovs.png].
    #[arg(short, long)]
    output: Option<PathBuf>,
}

/// Reads the EXR, writes its contact sheet, and prints one line per tile.
pub fn run(args: AovsArgs) -> Result<()> {
    let exr = read_exr(&args.exr)?;
    let sheet_path = args.output.unwrap_or_else(|| contact_sheet_path(&args.exr));
    let sheet = write_contact_sheet(&exr, &sheet_path)?;
    print!("{}", sheet.table(&args.exr, &exr));
    println!(
        "wrote {} ({}x{}{})",
        sheet_path.display(),
        sheet.width,
        sheet.height,
        if sheet.labelled {
            ", labelled"
        } else {
            "; no font for labels: tiles are at the row and column listed"
        }
    );
    Ok(())
}
