//! Pictures out: PNG (tiny-skia's `png` support) and animated GIF (the
//! `gif` crate; NeuQuant palette per frame).
//!
//! ```text
//! GIF frame k   only the rectangle that changed since frame k−1 is stored
//!               (disposal: keep), quantised to its own ≤ 256-colour palette
//! delay         `delay_cs` centiseconds per frame; the last frame is held
//!               `hold_cs` longer so the loop visibly restarts
//! ```

use crate::RenderError;
use tiny_skia::Pixmap;

/// An RGBA picture.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    pixmap: Pixmap,
}

impl Image {
    pub(crate) fn from_pixmap(pixmap: Pixmap) -> Image {
        Image { pixmap }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.pixmap.width()
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.pixmap.height()
    }

    /// Straight (not premultiplied) RGBA of pixel (x, y); `None` outside.
    pub fn pixel(&self, x: u32, y: u32) -> Option<[u8; 4]> {
        let c = self.pixmap.pixel(x, y)?.demultiply();
        Some([c.red(), c.green(), c.blue(), c.alpha()])
    }

    /// Straight RGBA bytes, row by row.
    pub fn rgba(&self) -> Vec<u8> {
        self.pixmap.clone().take_demultiplied()
    }

    /// PNG file bytes: 8-bit RGB (the pictures are opaque), best
    /// compression.
    pub fn to_png(&self) -> Result<Vec<u8>, RenderError> {
        let rgb: Vec<u8> = self
            .rgba()
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        self.write_png(png::ColorType::Rgb, None, &rgb)
    }

    /// PNG file bytes with a palette of at most `colors` colours (2..=256):
    /// lossy when the picture has more, much smaller (docs/gallery.md).
    pub fn to_png_indexed(&self, colors: usize) -> Result<Vec<u8>, RenderError> {
        if !(2..=256).contains(&colors) {
            return Err(RenderError::Encode {
                format: "png",
                message: format!("{colors} colours is outside 2..=256"),
            });
        }
        let (palette, indices) = quantize(&self.rgba(), colors);
        self.write_png(png::ColorType::Indexed, Some(palette), &indices)
    }

    fn write_png(
        &self,
        color: png::ColorType,
        palette: Option<Vec<u8>>,
        data: &[u8],
    ) -> Result<Vec<u8>, RenderError> {
        let png_error = |e: png::EncodingError| RenderError::Encode {
            format: "png",
            message: e.to_string(),
        };
        let mut out = Vec::new();
        let mut encoder = png::Encoder::new(&mut out, self.width(), self.height());
        encoder.set_color(color);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_compression(png::Compression::High);
        if let Some(palette) = palette {
            encoder.set_palette(palette);
        }
        let mut writer = encoder.write_header().map_err(png_error)?;
        writer.write_image_data(data).map_err(png_error)?;
        writer.finish().map_err(png_error)?;
        Ok(out)
    }

    /// Decodes PNG file bytes.
    pub fn from_png(bytes: &[u8]) -> Result<Image, RenderError> {
        Pixmap::decode_png(bytes)
            .map(Image::from_pixmap)
            .map_err(|e| RenderError::Encode {
                format: "png",
                message: e.to_string(),
            })
    }
}

fn gif_error(e: impl std::fmt::Display) -> RenderError {
    RenderError::Encode {
        format: "gif",
        message: e.to_string(),
    }
}

/// Streams pictures into an animated GIF held in memory.
pub struct GifEncoder {
    encoder: gif::Encoder<Vec<u8>>,
    width: u16,
    height: u16,
    delay_cs: u16,
    colors: usize,
    previous: Option<Vec<u8>>,
    pending: Option<gif::Frame<'static>>,
}

impl std::fmt::Debug for GifEncoder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GifEncoder")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("delay_cs", &self.delay_cs)
            .finish_non_exhaustive()
    }
}

impl GifEncoder {
    /// An endlessly looping animation of `width × height` pictures shown
    /// `delay_cs` centiseconds each (at least 2: browsers slow shorter
    /// delays down to 10), each with a palette of at most `colors` colours
    /// (2..=256; fewer colours, smaller file).
    pub fn new(
        width: u32,
        height: u32,
        delay_cs: u16,
        colors: usize,
    ) -> Result<GifEncoder, RenderError> {
        if !(2..=256).contains(&colors) {
            return Err(gif_error(format!("{colors} colours is outside 2..=256")));
        }
        let size = |v: u32| {
            u16::try_from(v)
                .map_err(|_| gif_error(format!("{v} pixels is over the GIF limit of 65535")))
        };
        let (width, height) = (size(width)?, size(height)?);
        let mut encoder = gif::Encoder::new(Vec::new(), width, height, &[]).map_err(gif_error)?;
        encoder
            .set_repeat(gif::Repeat::Infinite)
            .map_err(gif_error)?;
        Ok(GifEncoder {
            encoder,
            width,
            height,
            delay_cs: delay_cs.max(2),
            colors,
            previous: None,
            pending: None,
        })
    }

    /// Appends a picture.
    pub fn push(&mut self, image: &Image) -> Result<(), RenderError> {
        if image.width() != u32::from(self.width) || image.height() != u32::from(self.height) {
            return Err(gif_error(format!(
                "picture is {}x{}, the animation {}x{}",
                image.width(),
                image.height(),
                self.width,
                self.height
            )));
        }
        let rgba = image.rgba();
        let w = usize::from(self.width);
        // The rectangle that changed since the previous picture.
        let (x0, y0, x1, y1) = match &self.previous {
            None => (0, 0, w, usize::from(self.height)),
            Some(prev) => {
                let (mut x0, mut y0, mut x1, mut y1) = (w, usize::MAX, 0, 0);
                for (row, (a, b)) in rgba
                    .chunks_exact(4 * w)
                    .zip(prev.chunks_exact(4 * w))
                    .enumerate()
                {
                    if a == b {
                        continue;
                    }
                    let first = a
                        .chunks_exact(4)
                        .zip(b.chunks_exact(4))
                        .position(|(p, q)| p != q)
                        .unwrap_or(0);
                    let last = a
                        .chunks_exact(4)
                        .zip(b.chunks_exact(4))
                        .rposition(|(p, q)| p != q)
                        .unwrap_or(0);
                    x0 = x0.min(first);
                    x1 = x1.max(last + 1);
                    y0 = y0.min(row);
                    y1 = row + 1;
                }
                if y0 == usize::MAX {
                    (0, 0, 1, 1)
                } else {
                    (x0, y0, x1, y1)
                }
            }
        };
        let mut sub = Vec::with_capacity((x1 - x0) * (y1 - y0) * 4);
        for row in y0..y1 {
            sub.extend_from_slice(&rgba[(row * w + x0) * 4..(row * w + x1) * 4]);
        }
        // The rectangle lies inside a picture whose sides fit in u16.
        let narrow = |v: usize| u16::try_from(v).unwrap_or(u16::MAX);
        let (palette, indices) = quantize(&sub, self.colors);
        let mut frame = gif::Frame {
            width: narrow(x1 - x0),
            height: narrow(y1 - y0),
            palette: Some(palette),
            buffer: std::borrow::Cow::Owned(indices),
            ..gif::Frame::default()
        };
        frame.left = narrow(x0);
        frame.top = narrow(y0);
        frame.dispose = gif::DisposalMethod::Keep;
        self.flush(0)?;
        self.pending = Some(frame);
        self.previous = Some(rgba);
        Ok(())
    }

    fn flush(&mut self, extra_cs: u16) -> Result<(), RenderError> {
        if let Some(mut frame) = self.pending.take() {
            frame.delay = self.delay_cs.saturating_add(extra_cs);
            self.encoder.write_frame(&frame).map_err(gif_error)?;
        }
        Ok(())
    }

    /// Ends the animation, holding the last picture `hold_cs` centiseconds
    /// longer, and returns the GIF file bytes.
    pub fn finish(mut self, hold_cs: u16) -> Result<Vec<u8>, RenderError> {
        self.flush(hold_cs)?;
        self.encoder.into_inner().map_err(gif_error)
    }
}

/// A palette of at most `colors` colours (RGB) and one index per pixel:
/// exact when the pixels have that few colours, else NeuQuant.
fn quantize(rgba: &[u8], colors: usize) -> (Vec<u8>, Vec<u8>) {
    let mut exact: std::collections::BTreeSet<[u8; 3]> = std::collections::BTreeSet::new();
    for p in rgba.chunks_exact(4) {
        exact.insert([p[0], p[1], p[2]]);
        if exact.len() > colors {
            break;
        }
    }
    if exact.len() <= colors {
        let table: Vec<[u8; 3]> = exact.into_iter().collect();
        let palette = table.iter().flatten().copied().collect();
        let indices = rgba
            .chunks_exact(4)
            .map(|p| table.binary_search(&[p[0], p[1], p[2]]).unwrap_or(0) as u8)
            .collect();
        return (palette, indices);
    }
    let nq = color_quant::NeuQuant::new(10, colors, rgba);
    let indices = rgba.chunks_exact(4).map(|p| nq.index_of(p) as u8).collect();
    (nq.color_map_rgb(), indices)
}
