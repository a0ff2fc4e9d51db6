//! The images of a HaDaGe sequence: 16-bit grayscale PNG (depth, semantic ids) and
//! 8-bit RGB JPEG (colour).

use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::{Path, PathBuf};

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

/// Error unless an image's size is the expected one (checked before decoding).
fn check_size(path: &Path, found: (u32, u32), expected: Option<(u32, u32)>) -> Result<()> {
    let (width, height) = found;
    if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
        return Err(InputError::new(path, "size", format!("image of {width}x{height} pixels is outside 1..={MAX_SIDE}")));
    }
    match expected {
        Some((w, h)) if (w, h) != (width, height) => {
            Err(InputError::new(path, "size", format!("expected {w}x{h} pixels (camera_params.yaml), found {width}x{height}")))
        }
        _ => Ok(()),
    }
}

/// Read a 16-bit grayscale PNG, optionally requiring a size (checked before decoding).
pub fn read_png_gray16(path: &Path, expected: Option<(u32, u32)>) -> Result<GrayImage16> {
    let file = File::open(path).map_err(|e| InputError::io(path, &e))?;
    let mut decoder = png::Decoder::new(BufReader::new(file));
    decoder.set_transformations(png::Transformations::IDENTITY);
    let mut reader = decoder.read_info().map_err(|e| InputError::new(path, "(png)", format!("not a readable PNG: {e}")))?;
    let info = reader.info();
    let (width, height) = (info.width, info.height);
    check_size(path, (width, height), expected)?;
    // 8-bit images are refused: Open3D would scale them by 1/255, which no HaDaGe file wants.
    let (color, depth) = (info.color_type, info.bit_depth);
    if color != png::ColorType::Grayscale || depth != png::BitDepth::Sixteen {
        return Err(InputError::new(path, "IHDR", format!("expected a 16-bit grayscale PNG, found {color:?} with {depth:?} bits")));
    }
    let size = reader.output_buffer_size().ok_or_else(|| InputError::new(path, "IHDR", "image too large"))?;
    let mut buf = vec![0u8; size];
    let frame = reader.next_frame(&mut buf).map_err(|e| InputError::new(path, "IDAT", format!("image data is corrupt or truncated: {e}")))?;
    buf.truncate(frame.buffer_size());
    let pixels = buf.chunks_exact(2).map(|c| u16::from_be_bytes([c[0], c[1]])).collect();
    Ok(GrayImage16 { width, height, pixels })
}

/// How a 16-bit grayscale PNG is packed. Both read back to the same pixels; the choice
/// trades encoding time for bytes, by what the image holds (measured on 1200×680 frames of
/// a full release, docs/performance.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Packing {
    /// Each row's best filter, then fdeflate's fast mode: images of few distinct values
    /// (semantic labels: 14.5 KB in 1.7 ms a frame, the smallest of the settings tried).
    FewValues,
    /// The row above as the filter, then zlib's level 1: smooth gradients (planar depth:
    /// 242 KB in 7.4 ms a frame, against 433 KB in 3.5 ms packed as `FewValues`).
    Gradients,
}

/// Write a 16-bit grayscale PNG (what Pillow writes for mode `I;16`), packed for images of
/// few distinct values.
pub fn write_png_gray16(path: &Path, image: &GrayImage16) -> Result<()> {
    write_png_gray16_packed(path, image, Packing::FewValues)
}

/// Write a 16-bit grayscale PNG packed as `packing` says.
pub fn write_png_gray16_packed(path: &Path, image: &GrayImage16, packing: Packing) -> Result<()> {
    let file = File::create(path).map_err(|e| InputError::io(path, &e))?;
    encode_png_gray16(BufWriter::new(file), path, image, packing)
}

/// Write the same 16-bit grayscale PNG to every one of `paths`, encoded once.
pub fn write_png_gray16_to_all(paths: &[PathBuf], image: &GrayImage16, packing: Packing) -> Result<()> {
    let Some(first) = paths.first() else { return Ok(()) };
    let mut bytes = Vec::new();
    encode_png_gray16(&mut bytes, first, image, packing)?;
    paths.iter().try_for_each(|path| std::fs::write(path, &bytes).map_err(|e| InputError::io(path, &e)))
}

/// Encode `image` into `out`; errors name `path`.
fn encode_png_gray16(out: impl std::io::Write, path: &Path, image: &GrayImage16, packing: Packing) -> Result<()> {
    let mut encoder = png::Encoder::new(out, image.width, image.height);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Sixteen);
    match packing {
        Packing::FewValues => encoder.set_compression(png::Compression::Fast),
        Packing::Gradients => {
            encoder.set_deflate_compression(png::DeflateCompression::Level(1));
            encoder.set_filter(png::Filter::Up);
        }
    }
    let err = |e: png::EncodingError| InputError::new(path, "(png)", format!("cannot write PNG: {e}"));
    let mut writer = encoder.write_header().map_err(err)?;
    let bytes: Vec<u8> = image.pixels.iter().flat_map(|v| v.to_be_bytes()).collect();
    writer.write_image_data(&bytes).map_err(err)?;
    writer.finish().map_err(err)
}

/// Write an 8-bit RGB PNG (default compression).
pub fn write_png_rgb(path: &Path, image: &RgbImage) -> Result<()> {
    let file = File::create(path).map_err(|e| InputError::io(path, &e))?;
    let mut encoder = png::Encoder::new(BufWriter::new(file), image.width, image.height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let err = |e: png::EncodingError| InputError::new(path, "(png)", format!("cannot write PNG: {e}"));
    let mut writer = encoder.write_header().map_err(err)?;
    writer.write_image_data(&image.pixels).map_err(err)?;
    writer.finish().map_err(err)
}

/// Read a JPEG as 8-bit RGB (grayscale JPEGs are expanded), optionally requiring a size
/// (checked before decoding). jpeg-decoder follows libjpeg's integer IDCT closely: it
/// is within a few levels of libjpeg-turbo (Open3D, Pillow), where others differ more.
pub fn read_jpeg_rgb(path: &Path, expected: Option<(u32, u32)>) -> Result<RgbImage> {
    let file = File::open(path).map_err(|e| InputError::io(path, &e))?;
    let mut decoder = jpeg_decoder::Decoder::new(BufReader::new(file));
    let unreadable = |e: jpeg_decoder::Error| InputError::new(path, "(jpeg)", format!("not a readable JPEG: {e}"));
    decoder.read_info().map_err(unreadable)?;
    let info = decoder.info().ok_or_else(|| InputError::new(path, "(jpeg)", "JPEG has no frame header"))?;
    let (width, height) = (info.width as u32, info.height as u32);
    check_size(path, (width, height), expected)?;
    let raw = decoder.decode().map_err(unreadable)?;
    let pixels = match info.pixel_format {
        jpeg_decoder::PixelFormat::RGB24 => raw,
        jpeg_decoder::PixelFormat::L8 => raw.iter().flat_map(|&v| [v, v, v]).collect(),
        other => return Err(InputError::new(path, "(jpeg)", format!("expected an RGB or grayscale JPEG, found {other:?}"))),
    };
    if pixels.len() != (width * height * 3) as usize {
        return Err(InputError::new(path, "(jpeg)", "decoded JPEG does not fill its frame"));
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_packings_read_back_the_same_pixels_and_gradients_pack_smaller_as_gradients() {
        let dir = tempfile::tempdir().unwrap();
        // A tilted floor seen in depth millimetres: a gradient with steps, zero where nothing is hit.
        let (width, height) = (320u32, 180u32);
        let pixels: Vec<u16> = (0..width * height).map(|i| if i % width < 7 { 0 } else { (1500 + (i / width) * 17 + (i % width) / 3) as u16 }).collect();
        let image = GrayImage16 { width, height, pixels };
        let mut sizes = Vec::new();
        for packing in [Packing::FewValues, Packing::Gradients] {
            let path = dir.path().join(format!("{packing:?}.png"));
            write_png_gray16_packed(&path, &image, packing).unwrap();
            let back = read_png_gray16(&path, Some((width, height))).unwrap();
            assert_eq!(back.pixels, image.pixels, "{packing:?}");
            sizes.push(std::fs::metadata(&path).unwrap().len());
        }
        assert!(sizes[1] < sizes[0], "gradients pack smaller as Gradients: {sizes:?}");
    }

    #[test]
    fn an_image_written_to_several_paths_is_the_same_file_as_one_written_alone() {
        let dir = tempfile::tempdir().unwrap();
        let image = GrayImage16 { width: 64, height: 48, pixels: (0..64 * 48).map(|i| (i * 7 % 5000) as u16).collect() };
        let alone = dir.path().join("alone.png");
        write_png_gray16_packed(&alone, &image, Packing::Gradients).unwrap();
        let copies: Vec<PathBuf> = (0..3).map(|k| dir.path().join(format!("copy{k}.png"))).collect();
        write_png_gray16_to_all(&copies, &image, Packing::Gradients).unwrap();
        let expected = std::fs::read(&alone).unwrap();
        for copy in &copies {
            assert_eq!(std::fs::read(copy).unwrap(), expected, "{}", copy.display());
        }
        let missing = dir.path().join("no-such-folder").join("x.png");
        let err = write_png_gray16_to_all(&[copies[0].clone(), missing.clone()], &image, Packing::Gradients).unwrap_err();
        assert!(err.to_string().contains("no-such-folder"), "{err}");
    }
}
