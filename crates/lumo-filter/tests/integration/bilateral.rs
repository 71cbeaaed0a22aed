//! The cross bilateral filter against its spatial kernel.

use lumo_filter::*;
use lumo_image::Image;

use crate::support::*;

#[test]
fn bilateral_with_infinite_range_sigma_is_its_spatial_kernel() {
    let (w, h) = (33, 27);
    let c = noise_image(w, h, 3, 9);
    let s = split(w, h);
    let f = features(&s);
    let (r, sigma) = (4usize, 2.5f32);
    let p = BilateralParams {
        radius: r,
        sigma_spatial: sigma,
        sigma_normal: Some(f32::INFINITY),
        sigma_depth: Some(f32::INFINITY),
        sigma_position: Some(f32::INFINITY),
        sigma_color: Some(f32::INFINITY),
    };
    let got = bilateral(&c, &f, &p).unwrap().image;
    let mut want = Image::new(w, h, 3, 0.0);
    for y in 0..h as isize {
        for x in 0..w as isize {
            let (mut acc, mut k) = ([0.0f64; 3], 0.0f64);
            for dy in -(r as isize)..=r as isize {
                for dx in -(r as isize)..=r as isize {
                    let (xx, yy) = (x + dx, y + dy);
                    if xx < 0 || yy < 0 || xx >= w as isize || yy >= h as isize {
                        continue;
                    }
                    let wt = (-((dx * dx + dy * dy) as f64) / (2.0 * (sigma as f64).powi(2))).exp();
                    for ch in 0..3 {
                        acc[ch] += wt * c.pixel(xx as usize, yy as usize)[ch] as f64;
                    }
                    k += wt;
                }
            }
            for ch in 0..3 {
                want.pixel_mut(x as usize, y as usize)[ch] = (acc[ch] / k) as f32;
            }
        }
    }
    let d = max_abs_diff(&got, &want);
    assert!(d < 1e-5, "{d}");
}
