//! The images of a HaDaGe sequence: 16-bit grayscale PNG (depth, semantic ids) and
//! 8-bit RGB JPEG (colour).

use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::Path;

use crate::error::{InputError, Result};

/// Largest image side accepted from outside.
const MAX_SIDE: u32 = 16_384;

/// A single-channel 16-bit image, row-major.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GrayImage16 {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` samples.
    pub pixels: Vec<u16>,
}

/// An 8-bit RGB image, row-major, 3 bytes per pixel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RgbImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height * 3` bytes.
    pub pixels: Vec<u8>,
}

/// Read a 16-bit (or 8-bit, widened) grayscale PNG.
pub fn read_png_gray16(path: &Path) -> Result<GrayImage16> {
    let file = File::open(path).map_err(|e| InputError::io(path, &e))?;
    let mut decoder = png::Decoder::new(BufReader::new(file));
    decoder.set_transformations(png::Transformations::IDENTITY);
    let mut reader = decoder.read_info().map_err(|e| InputError::new(path, "(png)", format!("not a readable PNG: {e}")))?;
    let info = reader.info();
    let (width, height) = (info.width, info.height);
    if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
        return Err(InputError::new(path, "IHDR", format!("image of {width}x{height} pixels is outside 1..={MAX_SIDE}")));
    }
    let (color, depth) = (info.color_type, info.bit_depth);
    if color != png::ColorType::Grayscale || !matches!(depth, png::BitDepth::Sixteen | png::BitDepth::Eight) {
        return Err(InputError::new(path, "IHDR", format!("expected a 16-bit grayscale PNG, found {color:?} with {depth:?} bits")));
    }
    let size = reader.output_buffer_size().ok_or_else(|| InputError::new(path, "IHDR", "image too large"))?;
    let mut buf = vec![0u8; size];
    let frame = reader.next_frame(&mut buf).map_err(|e| InputError::new(path, "IDAT", format!("image data is corrupt or truncated: {e}")))?;
    buf.truncate(frame.buffer_size());
    let pixels = match depth {
        png::BitDepth::Sixteen => buf.chunks_exact(2).map(|c| u16::from_be_bytes([c[0], c[1]])).collect(),
        _ => buf.iter().map(|&b| b as u16).collect(),
    };
    Ok(GrayImage16 { width, height, pixels })
}

/// Write a 16-bit grayscale PNG (what Pillow writes for mode `I;16`).
pub fn write_png_gray16(path: &Path, image: &GrayImage16) -> Result<()> {
    let file = File::create(path).map_err(|e| InputError::io(path, &e))?;
    let mut encoder = png::Encoder::new(BufWriter::new(file), image.width, image.height);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Sixteen);
    encoder.set_compression(png::Compression::Fast);
    let err = |e: png::EncodingError| InputError::new(path, "(png)", format!("cannot write PNG: {e}"));
    let mut writer = encoder.write_header().map_err(err)?;
    let bytes: Vec<u8> = image.pixels.iter().flat_map(|v| v.to_be_bytes()).collect();
    writer.write_image_data(&bytes).map_err(err)?;
    writer.finish().map_err(err)
}

/// Read a JPEG as 8-bit RGB.
pub fn read_jpeg_rgb(path: &Path) -> Result<RgbImage> {
    let bytes = std::fs::read(path).map_err(|e| InputError::io(path, &e))?;
    let options = zune_jpeg::zune_core::options::DecoderOptions::default()
        .jpeg_set_out_colorspace(zune_jpeg::zune_core::colorspace::ColorSpace::RGB)
        .set_max_width(MAX_SIDE as usize)
        .set_max_height(MAX_SIDE as usize);
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(std::io::Cursor::new(&bytes), options);
    let pixels = decoder.decode().map_err(|e| InputError::new(path, "(jpeg)", format!("not a readable JPEG: {e}")))?;
    let (width, height) = decoder.dimensions().map(|(w, h)| (w as u32, h as u32)).ok_or_else(|| InputError::new(path, "(jpeg)", "JPEG has no dimensions"))?;
    if pixels.len() != (width * height * 3) as usize {
        return Err(InputError::new(path, "(jpeg)", "decoded JPEG is not 3-channel RGB"));
    }
    Ok(RgbImage { width, height, pixels })
}

/// Write an RGB JPEG at `quality` (Pillow's default is 75).
pub fn write_jpeg_rgb(path: &Path, image: &RgbImage, quality: u8) -> Result<()> {
    let encoder = jpeg_encoder::Encoder::new_file(path, quality).map_err(|e| InputError::new(path, "(jpeg)", format!("cannot write JPEG: {e}")))?;
    encoder
        .encode(&image.pixels, image.width as u16, image.height as u16, jpeg_encoder::ColorType::Rgb)
        .map_err(|e| InputError::new(path, "(jpeg)", format!("cannot write JPEG: {e}")))
}
