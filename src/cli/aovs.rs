//! `cirrus aovs OUT.exr [-o SHEET.png]`: a contact sheet of every layer of an
//! EXR (beauty, AOVs, Cryptomattes) and the list of its layers.

use std::path::{Path, PathBuf};

use anyhow::Result;

use cirrus::image::{read_exr, ChannelFormat, ExrChannels, StoredChannel};
use cirrus::output::{write_contact_sheet, ContactSheet};

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
    let sheet_path = args.output.unwrap_or_else(|| default_sheet_path(&args.exr));
    let sheet = write_contact_sheet(&exr, &sheet_path)?;
    print!("{}", tile_table(&args.exr, &exr, &sheet));
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

/// `NAME.aovs.png` beside `NAME.exr`.
fn default_sheet_path(exr: &Path) -> PathBuf {
    exr.with_extension("aovs.png")
}

/// The file's size and channel count, then per tile its grid position, layer
/// name, and channels with their stored type (once when they all share it).
fn tile_table(path: &Path, exr: &ExrChannels, sheet: &ContactSheet) -> String {
    let mut out = format!(
        "{}: {}x{}, {} channels, {} layers\n",
        path.display(),
        exr.width,
        exr.height,
        exr.channels.len(),
        sheet.tiles.len()
    );
    out += &format!("  {:<4}{:<7}{:<20}channels\n", "row", "column", "layer");
    for tile in &sheet.tiles {
        let channels: Vec<&StoredChannel> =
            tile.channels.iter().map(|&c| &exr.channels[c]).collect();
        let shared = channels.iter().all(|c| c.format == channels[0].format);
        let listed: Vec<String> = if shared {
            let names: Vec<&str> = channels.iter().map(|c| c.name.as_str()).collect();
            vec![format!(
                "{} ({})",
                names.join(" "),
                format_name(channels[0].format)
            )]
        } else {
            channels
                .iter()
                .map(|c| format!("{} ({})", c.name, format_name(c.format)))
                .collect()
        };
        out += &format!(
            "  {:<4}{:<7}{:<20}{}\n",
            tile.row,
            tile.column,
            tile.layer,
            listed.join(" ")
        );
    }
    out
}

/// How OpenEXR names a pixel type.
fn format_name(format: ChannelFormat) -> &'static str {
    match format {
        ChannelFormat::Half => "half",
        ChannelFormat::Float => "float",
        ChannelFormat::Uint => "uint",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sheet_goes_beside_the_exr() {
        assert_eq!(
            default_sheet_path(Path::new("/renders/shot.0101.exr")),
            Path::new("/renders/shot.0101.aovs.png")
        );
    }
}
