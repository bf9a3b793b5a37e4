//! Density fields as grey-scale PNG images: black is solid (ρ = 1), white is void (ρ = 0),
//! the top row of the image is the top edge of the domain (y = w).

use std::io::Cursor;

use image::{GrayImage, ImageFormat, Luma};

/// Errors of the image reader and writer.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// PNG encoding or decoding failed.
    #[error("PNG encoding or decoding failed")]
    Png(#[from] image::ImageError),
    /// The image does not have the mesh's size.
    #[error("the image is {width} x {height} pixels; expected a multiple of the mesh {nl} x {nw}")]
    Size {
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
        /// Elements along x.
        nl: usize,
        /// Elements along y.
        nw: usize,
    },
}

/// Encodes a density field as PNG. `rho(i, j)` is the density of the element in column `i`
/// (along x, from the left) and row `j` (along y, from the bottom); each element becomes a
/// `scale × scale` block of pixels.
pub fn density_png(
    nl: usize,
    nw: usize,
    scale: u32,
    rho: impl Fn(usize, usize) -> f64,
) -> Result<Vec<u8>, ImageError> {
    let scale = scale.max(1);
    let (w, h) = (nl as u32 * scale, nw as u32 * scale);
    let img = GrayImage::from_fn(w, h, |x, y| {
        let i = (x / scale) as usize;
        let j = nw - 1 - (y / scale) as usize;
        let v = rho(i, j).clamp(0.0, 1.0);
        Luma([(255.0 * (1.0 - v)).round() as u8])
    });
    let mut bytes = Vec::new();
    img.write_to(&mut Cursor::new(&mut bytes), ImageFormat::Png)?;
    Ok(bytes)
}

/// Decodes a density field from an image of `nl·s × nw·s` pixels (any integer `s ≥ 1`), the
/// inverse of [`density_png`]: returns `rho[j * nl + i]` for column `i`, row `j` (from the
/// bottom), averaging each block.
pub fn read_density_png(bytes: &[u8], nl: usize, nw: usize) -> Result<Vec<f64>, ImageError> {
    let img = image::load_from_memory(bytes)?.to_luma8();
    let (w, h) = img.dimensions();
    let size_err = ImageError::Size {
        width: w,
        height: h,
        nl,
        nw,
    };
    if nl == 0 || nw == 0 || w as usize % nl != 0 || h as usize % nw != 0 {
        return Err(size_err);
    }
    let (sx, sy) = (w as usize / nl, h as usize / nw);
    if sx != sy {
        return Err(size_err);
    }
    let mut rho = vec![0.0; nl * nw];
    for j in 0..nw {
        for i in 0..nl {
            let mut sum = 0.0;
            for dy in 0..sy {
                for dx in 0..sx {
                    let x = (i * sx + dx) as u32;
                    let y = ((nw - 1 - j) * sy + dy) as u32;
                    sum += 1.0 - img.get_pixel(x, y)[0] as f64 / 255.0;
                }
            }
            rho[j * nl + i] = sum / (sx * sy) as f64;
        }
    }
    Ok(rho)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_round_trip_within_quantization() {
        let (nl, nw) = (7, 3);
        let f = |i: usize, j: usize| (i as f64 + 2.0 * j as f64) / 12.0;
        let png = density_png(nl, nw, 4, f).unwrap();
        let back = read_density_png(&png, nl, nw).unwrap();
        for j in 0..nw {
            for i in 0..nl {
                assert!((back[j * nl + i] - f(i, j)).abs() <= 0.5 / 255.0 + 1e-12);
            }
        }
        // Orientation: element (0, nw-1) is at the top-left pixel.
        let img = image::load_from_memory(&png).unwrap().to_luma8();
        let top_left = 1.0 - img.get_pixel(0, 0)[0] as f64 / 255.0;
        assert!((top_left - f(0, nw - 1)).abs() < 0.01);
    }

    #[test]
    fn wrong_size_is_rejected() {
        let png = density_png(4, 2, 1, |_, _| 1.0).unwrap();
        assert!(matches!(
            read_density_png(&png, 3, 2),
            Err(ImageError::Size { .. })
        ));
    }
}
