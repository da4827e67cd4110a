//! Frames to PNG files: screenshots, the recorded sequence, and the headless renderer's output.
//! Nothing is overwritten: a path that exists is an error (or skipped to the next free name, for
//! screenshots), so no file a user saved is lost.

use anyhow::{bail, Context, Result};
use std::fs::{File, OpenOptions};
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// An RGBA8 image, rows top to bottom.
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub rgba: Vec<u8>,
}

impl Image {
    /// From glReadPixels output, whose rows run bottom to top.
    pub fn from_gl_rows(width: u32, height: u32, mut bottom_up: Vec<u8>) -> Image {
        let row = 4 * width as usize;
        let rows: Vec<Vec<u8>> = bottom_up.chunks_exact(row).rev().map(<[u8]>::to_vec).collect();
        bottom_up.clear();
        for r in rows {
            bottom_up.extend_from_slice(&r);
        }
        Image {
            width,
            height,
            rgba: bottom_up,
        }
    }

    /// Writes a PNG at `path`, refusing to replace an existing file.
    pub fn write_png_new(&self, path: &Path) -> Result<()> {
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(path)
            .with_context(|| match path.exists() {
                true => format!("{} exists already; not overwriting it", path.display()),
                false => format!("cannot create {}", path.display()),
            })?;
        self.encode(file)
            .with_context(|| format!("writing {}", path.display()))
    }

    fn encode(&self, file: File) -> Result<()> {
        let mut encoder = png::Encoder::new(BufWriter::new(file), self.width, self.height);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header()?;
        writer.write_image_data(&self.rgba)?;
        writer.finish()?;
        Ok(())
    }

    /// Decodes a PNG (for tests and reference checks).
    pub fn read_png(bytes: &[u8]) -> Result<Image> {
        let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::ALPHA);
        let mut reader = decoder.read_info()?;
        let mut buffer = vec![0; reader.output_buffer_size().context("PNG too large")?];
        let info = reader.next_frame(&mut buffer)?;
        buffer.truncate(info.buffer_size());
        let channels = info.color_type.samples();
        let rgba = match channels {
            4 => buffer,
            3 => buffer
                .chunks_exact(3)
                .flat_map(|c| [c[0], c[1], c[2], 255])
                .collect(),
            _ => bail!("unsupported PNG colour type {:?}", info.color_type),
        };
        Ok(Image {
            width: info.width,
            height: info.height,
            rgba,
        })
    }

    /// Statistics that tell a frame with fluid in it from an empty or broken one.
    pub fn stats(&self) -> ImageStats {
        let background = super::renderer::BACKGROUND.map(|c| (c * 255.0).round() as i32);
        let pixels = (self.width as usize * self.height as usize).max(1);
        let (mut mean, mut covered) = ([0f64; 3], 0usize);
        let (mut cx, mut cy) = (0f64, 0f64);
        for (i, px) in self.rgba.chunks_exact(4).enumerate() {
            for k in 0..3 {
                mean[k] += f64::from(px[k]);
            }
            let differs = (0..3).any(|k| (i32::from(px[k]) - background[k]).abs() > 12);
            if differs {
                covered += 1;
                cx += (i % self.width as usize) as f64;
                cy += (i / self.width as usize) as f64;
            }
        }
        let covered_f = covered.max(1) as f64;
        ImageStats {
            mean_rgb: mean.map(|m| m / pixels as f64),
            covered_fraction: covered as f64 / pixels as f64,
            centroid: [
                cx / covered_f / f64::from(self.width.max(1)),
                cy / covered_f / f64::from(self.height.max(1)),
            ],
        }
    }
}

/// Image statistics, as fractions of the frame so sizes compare.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ImageStats {
    /// Mean of each channel, 0..255.
    pub mean_rgb: [f64; 3],
    /// Fraction of pixels that differ from the background (fluid, box, colour bar).
    pub covered_fraction: f64,
    /// Centre of the covered pixels, as fractions of width and height (y down).
    pub centroid: [f64; 2],
}

/// Numbered frame files `frame-00000.png`, ... in a directory, none of which may exist yet.
/// Dropped before its first frame (the run failed before it began: no GPU, no EGL), it removes the
/// directories it created, so a failure leaves nothing behind.
pub struct FrameSequence {
    dir: PathBuf,
    next: u64,
    /// The directories `create` made, deepest first.
    created: Vec<PathBuf>,
}

impl FrameSequence {
    /// Creates `dir` if needed and checks that it is writable and holds no frames this run would
    /// overwrite (the first `frames` names).
    pub fn create(dir: &Path, frames: u64) -> Result<FrameSequence> {
        if dir.exists() && !dir.is_dir() {
            bail!(
                "{} is a file, not a directory; give a directory for the frames",
                dir.display()
            );
        }
        let created: Vec<PathBuf> = dir
            .ancestors()
            .take_while(|a| !a.as_os_str().is_empty() && !a.exists())
            .map(Path::to_path_buf)
            .collect();
        let sequence = FrameSequence {
            dir: dir.to_path_buf(),
            next: 0,
            created,
        };
        std::fs::create_dir_all(dir).map_err(|e| {
            anyhow::anyhow!(
                "cannot create the output directory {}: {}",
                dir.display(),
                crate::text::io_reason(&e)
            )
        })?;
        let probe = dir.join(".mpm-write-test");
        File::create(&probe).map_err(|e| {
            anyhow::anyhow!(
                "the output directory {} is not writable: {}",
                dir.display(),
                crate::text::io_reason(&e)
            )
        })?;
        let _ = std::fs::remove_file(&probe);
        if let Some(existing) = (0..frames).map(|i| sequence.path(i)).find(|p| p.exists()) {
            bail!(
                "{} exists already; choose an empty --out directory (nothing was overwritten)",
                existing.display()
            );
        }
        Ok(sequence)
    }

    pub fn path(&self, index: u64) -> PathBuf {
        self.dir.join(format!("frame-{index:05}.png"))
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    pub fn frames_written(&self) -> u64 {
        self.next
    }

    pub fn write(&mut self, image: &Image) -> Result<PathBuf> {
        let path = self.path(self.next);
        image.write_png_new(&path)?;
        self.next += 1;
        Ok(path)
    }
}

impl Drop for FrameSequence {
    fn drop(&mut self) {
        if self.next == 0 {
            // Deepest first; remove_dir refuses a directory that is not empty, so nothing a user
            // put there can go.
            for dir in &self.created {
                if std::fs::remove_dir(dir).is_err() {
                    break;
                }
            }
        }
    }
}

/// The first `screenshot-NNN.png` in `dir` that does not exist yet.
pub fn next_free_screenshot(dir: &Path) -> PathBuf {
    (0..)
        .map(|i| dir.join(format!("screenshot-{i:03}.png")))
        .find(|p| !p.exists())
        .unwrap_or_else(|| dir.join("screenshot.png"))
}
