//! RGBA8 images, rectangles and PNG files.

use crate::{MAX_SIDE, RenderError, Rgba};

/// An axis-aligned rectangle of pixels: columns `x .. x + width`, rows
/// `y .. y + height` (y grows downwards). It may reach outside an image;
/// drawing clips.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Rect {
    /// Left column.
    pub x: i32,
    /// Top row.
    pub y: i32,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

impl Rect {
    /// The rectangle with top-left corner `(x, y)` and the given size.
    pub const fn new(x: i32, y: i32, width: u32, height: u32) -> Self {
        Self {
            x,
            y,
            width,
            height,
        }
    }

    /// One past the right column, `x + width` (as i64: no overflow).
    pub fn right(&self) -> i64 {
        i64::from(self.x) + i64::from(self.width)
    }

    /// One past the bottom row, `y + height` (as i64: no overflow).
    pub fn bottom(&self) -> i64 {
        i64::from(self.y) + i64::from(self.height)
    }

    /// Whether pixel `(px, py)` lies in the rectangle.
    pub fn contains(&self, px: i64, py: i64) -> bool {
        px >= i64::from(self.x)
            && px < self.right()
            && py >= i64::from(self.y)
            && py < self.bottom()
    }

    /// Whether the rectangle holds no pixel.
    pub fn is_empty(&self) -> bool {
        self.width == 0 || self.height == 0
    }
}

/// An RGBA8 image, row-major from the top-left pixel, straight alpha.
///
/// `width` and `height` are in 1..=[`MAX_SIDE`]. Pixel `(x, y)` covers the
/// square `[x, x + 1) x [y, y + 1)` of pixel space, its centre is
/// `(x + 0.5, y + 0.5)`; y grows downwards.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image {
    width: u32,
    height: u32,
    data: Vec<u8>,
}

impl Image {
    /// A `width x height` image filled with `background`.
    ///
    /// Errors with [`RenderError::InvalidSize`] if a side is 0 or larger than
    /// [`MAX_SIDE`].
    pub fn new(width: u32, height: u32, background: Rgba) -> Result<Self, RenderError> {
        check_size(width, height)?;
        let n = width as usize * height as usize;
        let mut data = Vec::with_capacity(4 * n);
        for _ in 0..n {
            data.extend_from_slice(&[background.r, background.g, background.b, background.a]);
        }
        Ok(Self {
            width,
            height,
            data,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The whole image as a rectangle at the origin.
    pub fn rect(&self) -> Rect {
        Rect::new(0, 0, self.width, self.height)
    }

    /// The raw RGBA8 bytes, row-major, 4 per pixel.
    pub fn as_bytes(&self) -> &[u8] {
        &self.data
    }

    /// Byte offset of pixel `(x, y)` if it lies inside the image.
    fn offset(&self, x: i64, y: i64) -> Option<usize> {
        if x < 0 || y < 0 || x >= i64::from(self.width) || y >= i64::from(self.height) {
            None
        } else {
            Some(4 * (y as usize * self.width as usize + x as usize))
        }
    }

    /// The colour of pixel `(x, y)`, or `None` outside the image.
    pub fn get(&self, x: i64, y: i64) -> Option<Rgba> {
        self.offset(x, y).map(|o| {
            let d = &self.data[o..o + 4];
            Rgba::new(d[0], d[1], d[2], d[3])
        })
    }

    /// Sets pixel `(x, y)` to `c` (no blending). Outside the image this is a
    /// no-op; the return value says whether a pixel was written.
    pub fn put(&mut self, x: i64, y: i64, c: Rgba) -> bool {
        match self.offset(x, y) {
            Some(o) => {
                self.data[o..o + 4].copy_from_slice(&[c.r, c.g, c.b, c.a]);
                true
            }
            None => false,
        }
    }

    /// Copies `src` with its top-left corner at `(x, y)` of this image (no
    /// blending); the parts falling outside this image are dropped. Used to
    /// compose panels into a figure.
    pub fn blit(&mut self, src: &Image, x: i64, y: i64) {
        let x0 = x.max(0);
        let x1 = (x + i64::from(src.width)).min(i64::from(self.width));
        if x0 >= x1 {
            return;
        }
        let y0 = y.max(0);
        let y1 = (y + i64::from(src.height)).min(i64::from(self.height));
        for dy in y0..y1 {
            let sy = dy - y;
            let s = 4 * (sy as usize * src.width as usize + (x0 - x) as usize);
            let d = 4 * (dy as usize * self.width as usize + x0 as usize);
            let n = 4 * (x1 - x0) as usize;
            self.data[d..d + n].copy_from_slice(&src.data[s..s + n]);
        }
    }

    /// Encodes the image as an 8-bit RGBA PNG.
    ///
    /// The settings are fixed (no interlacing, adaptive filtering, zlib level
    /// 6, no text or time chunks), so the same pixels always give the same
    /// bytes.
    pub fn to_png(&self) -> Result<Vec<u8>, RenderError> {
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, self.width, self.height);
            enc.set_color(png::ColorType::Rgba);
            enc.set_depth(png::BitDepth::Eight);
            enc.set_deflate_compression(png::DeflateCompression::Level(6));
            enc.set_filter(png::Filter::Adaptive);
            let mut w = enc
                .write_header()
                .map_err(|e| RenderError::Png(e.to_string()))?;
            w.write_image_data(&self.data)
                .map_err(|e| RenderError::Png(e.to_string()))?;
            w.finish().map_err(|e| RenderError::Png(e.to_string()))?;
        }
        Ok(out)
    }

    /// Decodes a PNG (any colour type and bit depth; palettes are expanded,
    /// 16-bit samples reduced to 8 bits, grey replicated, missing alpha set
    /// to 255).
    pub fn from_png(bytes: &[u8]) -> Result<Self, RenderError> {
        let err = |e: png::DecodingError| RenderError::Png(e.to_string());
        let mut dec = png::Decoder::new(std::io::Cursor::new(bytes));
        dec.set_transformations(png::Transformations::normalize_to_color8());
        let mut reader = dec.read_info().map_err(err)?;
        // Checked before allocating: a header may claim any size.
        check_size(reader.info().width, reader.info().height)?;
        let size = reader
            .output_buffer_size()
            .ok_or_else(|| RenderError::Png("image too large".into()))?;
        let mut buf = vec![0u8; size];
        let info = reader.next_frame(&mut buf).map_err(err)?;
        check_size(info.width, info.height)?;
        let (w, h) = (info.width as usize, info.height as usize);
        let channels = match info.color_type {
            png::ColorType::Grayscale => 1,
            png::ColorType::GrayscaleAlpha => 2,
            png::ColorType::Rgb => 3,
            png::ColorType::Rgba => 4,
            png::ColorType::Indexed => {
                return Err(RenderError::Png("indexed colour was not expanded".into()));
            }
        };
        if info.bit_depth != png::BitDepth::Eight {
            return Err(RenderError::Png(format!(
                "unexpected bit depth {:?}",
                info.bit_depth
            )));
        }
        let mut data = Vec::with_capacity(4 * w * h);
        for row in 0..h {
            let line = &buf[row * info.line_size..row * info.line_size + channels * w];
            for px in line.chunks_exact(channels) {
                let rgba = match channels {
                    1 => [px[0], px[0], px[0], 255],
                    2 => [px[0], px[0], px[0], px[1]],
                    3 => [px[0], px[1], px[2], 255],
                    _ => [px[0], px[1], px[2], px[3]],
                };
                data.extend_from_slice(&rgba);
            }
        }
        Ok(Self {
            width: info.width,
            height: info.height,
            data,
        })
    }

    /// Fills every pixel of `rect` that lies in the image with `c`.
    pub fn fill_rect(&mut self, rect: Rect, c: Rgba) {
        let x0 = i64::from(rect.x).max(0);
        let x1 = rect.right().min(i64::from(self.width));
        let y0 = i64::from(rect.y).max(0);
        let y1 = rect.bottom().min(i64::from(self.height));
        for y in y0..y1 {
            for x in x0..x1 {
                self.put(x, y, c);
            }
        }
    }

    /// Draws the 1-pixel outline of `rect` (its outermost rows and columns).
    pub fn stroke_rect(&mut self, rect: Rect, c: Rgba) {
        if rect.is_empty() {
            return;
        }
        let (x0, y0) = (i64::from(rect.x), i64::from(rect.y));
        let (x1, y1) = (rect.right() - 1, rect.bottom() - 1);
        for x in x0.max(-1)..=x1.min(i64::from(self.width)) {
            self.put(x, y0, c);
            self.put(x, y1, c);
        }
        for y in y0.max(-1)..=y1.min(i64::from(self.height)) {
            self.put(x0, y, c);
            self.put(x1, y, c);
        }
    }
}

/// Checks that `width x height` is a valid image size.
pub(crate) fn check_size(width: u32, height: u32) -> Result<(), RenderError> {
    if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
        Err(RenderError::InvalidSize { width, height })
    } else {
        Ok(())
    }
}
