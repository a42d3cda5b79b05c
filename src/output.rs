//! Writing result files: whole or not at all.

use crate::error::{Context, Result, bail};
use std::path::Path;

/// Image formats the commands write, chosen by the output file's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// Linear RGB, 32-bit float.
    Exr,
    /// 8-bit sRGB.
    Png,
}

impl ImageFormat {
    pub fn from_path(path: &Path) -> Result<ImageFormat> {
        match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("exr") => Ok(ImageFormat::Exr),
            Some("png") => Ok(ImageFormat::Png),
            _ => bail!("{}: unsupported output type (use .exr or .png)", path.display()),
        }
    }
}

/// Refuses an output path whose folder does not exist or cannot be written, before the work
/// that would fill it (by creating and removing a file there).
pub fn ensure_writable(path: &Path) -> Result<()> {
    temporary_beside(path).map(drop)
}

/// A temporary file in `path`'s folder, with its extension.
fn temporary_beside(path: &Path) -> Result<tempfile::NamedTempFile> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        bail!("{}: the folder {} does not exist", path.display(), dir.display());
    }
    let suffix = path.extension().map(|e| format!(".{}", e.to_string_lossy())).unwrap_or_default();
    let tmp = tempfile::Builder::new().prefix(".dualhair-").suffix(&suffix).tempfile_in(dir);
    tmp.with_context(|| format!("{}: cannot create a file in the folder {}", path.display(), dir.display()))
}

/// Runs `write` on a temporary file beside `path` and renames it into place only if it succeeds,
/// so an error or interrupt never leaves a half-written output.
pub fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let tmp = temporary_beside(path)?;
    write(tmp.path()).with_context(|| format!("{}: writing failed", path.display()))?;
    // Temporary files are private (0600); a finished output is an ordinary file (0644).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(tmp.path(), std::fs::Permissions::from_mode(0o644))
            .with_context(|| format!("{}: cannot set the file's permissions", path.display()))?;
    }
    tmp.persist(path)
        .map_err(|e| e.error)
        .with_context(|| format!("{}: cannot move the finished file into place", path.display()))?;
    Ok(())
}

/// Writes linear RGB pixels (rows top to bottom) as a 32-bit float EXR.
pub fn write_exr(path: &Path, width: usize, height: usize, pixels: &[[f32; 3]]) -> Result<()> {
    use exr::prelude::{Encoding, Image, LineOrder, SpecificChannels, Vec2, WritableImage};
    // Chunks in increasing order: compressed in parallel, they would otherwise be written as they
    // finish, and the file's bytes would differ from run to run (its pixels would not).
    let encoding = Encoding { line_order: LineOrder::Increasing, ..Encoding::FAST_LOSSLESS };
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let [r, g, b] = pixels[y * width + x];
        (r, g, b)
    });
    let image = Image::from_encoded_channels((width, height), encoding, channels);
    write_atomically(path, |tmp| Ok(image.write().to_file(tmp)?))
}

/// Writes an 8-bit RGB image as PNG.
pub fn write_png(path: &Path, image: &image::RgbImage) -> Result<()> {
    write_atomically(path, |tmp| Ok(image.save_with_format(tmp, image::ImageFormat::Png)?))
}
