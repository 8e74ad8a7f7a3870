//! `mixmc-composite`: eq. (2) per pixel, FXAA only on the mask's borders, the MCMC-only switch,
//! the mask-hash warnings and size errors.

use crate::util::*;
use mixmc::composite::mask_borders;
use mixmc::exrio::ExrImage;
use mixmc::fingerprint::{MASK_HASH_ATTR, MASK_PATH_ATTR, alpha_hash};
use mixmc::scene::SCENE_HASH_ATTR;
use std::path::{Path, PathBuf};

const EPS: f32 = 0.1;

/// Synthetic inputs: D, I_omc and I_mcmc as given, a mask of `alpha`, and an MCMC header naming
/// `mcmc_mask_alpha` (None: no mask named).
struct Inputs {
    omc: PathBuf,
    mask: PathBuf,
    mcmc: PathBuf,
}

fn write_inputs(
    dir: &Path,
    (w, h): (usize, usize),
    d: &[[f32; 3]],
    i_omc: &[[f32; 3]],
    alpha: &[f32],
    i_mcmc: &[[f32; 3]],
    mcmc_mask_alpha: Option<&[f32]>,
) -> Inputs {
    const RGB: [&str; 3] = ["R", "G", "B"];
    std::fs::create_dir_all(dir).unwrap();
    let mut omc = ExrImage::new(w, h);
    let beauty: Vec<[f32; 3]> = d
        .iter()
        .zip(i_omc)
        .map(|(a, b)| std::array::from_fn(|c| a[c] + b[c]))
        .collect();
    omc.add_rgb("", RGB, &beauty);
    omc.add_rgb("direct", RGB, d);
    omc.add_rgb("indirect", RGB, i_omc);
    omc.set_text("mixmc.tool", "mixmc-omc");
    omc.set_text("mixmc.scene", "synthetic.json");
    let mut mask = ExrImage::new(w, h);
    mask.add("alpha", alpha.to_vec());
    for ch in ["segment", "noise", "weight"] {
        mask.add(ch, vec![0.0; w * h]);
    }
    let mut mcmc = ExrImage::new(w, h);
    mcmc.add_rgb("", RGB, i_mcmc);
    mcmc.set_text("mixmc.scene", "synthetic.json");
    if let Some(a) = mcmc_mask_alpha {
        mcmc.set_text(MASK_PATH_ATTR, "the-mask.exr");
        mcmc.set_text(MASK_HASH_ATTR, alpha_hash(w, h, a));
    }
    let inputs = Inputs {
        omc: dir.join("omc.exr"),
        mask: dir.join("mask.exr"),
        mcmc: dir.join("mcmc.exr"),
    };
    omc.write(&inputs.omc, false).unwrap();
    mask.write(&inputs.mask, false).unwrap();
    mcmc.write(&inputs.mcmc, false).unwrap();
    inputs
}

/// Run the compositor; returns the output image and stderr.
fn composite(dir: &Path, inputs: &Inputs, extra: &[&str]) -> (ExrImage, String) {
    let out = dir.join("final.exr");
    let mut args = vec![
        "--omc",
        path_str(&inputs.omc),
        "--mask",
        path_str(&inputs.mask),
        "--mcmc",
        path_str(&inputs.mcmc),
    ];
    args.extend_from_slice(&["-o", path_str(&out)]);
    args.extend_from_slice(extra);
    let o = run_code(COMPOSITE, &args, 0);
    (ExrImage::read(&out).unwrap(), stderr(&o))
}

/// D, I_omc and I_mcmc (in that order): random RGB from streams `first`, `first + 1` and
/// `first + 2`, scaled by `scales`.
fn random_light(n: usize, first: u64, scales: [f32; 3]) -> [Vec<[f32; 3]>; 3] {
    std::array::from_fn(|k| {
        (0..n)
            .map(|i| std::array::from_fn(|c| scales[k] * noise(3 * i + c, first + k as u64)))
            .collect()
    })
}

fn eq2(d: &[[f32; 3]], i: &[[f32; 3]], alpha: &[f32], m: &[[f32; 3]]) -> Vec<[f32; 3]> {
    (0..d.len())
        .map(|p| std::array::from_fn(|c| d[p][c] + i[p][c] * (1.0 - alpha[p]) + m[p][c]))
        .collect()
}

#[test]
fn equation2_holds_per_pixel_and_fxaa_stays_on_borders() {
    let dir = temp_dir("eq2");
    let (w, h) = (24, 16);
    let n = w * h;
    // Display-range values: FXAA judges edges by clamped luma, so it leaves saturated pixels alone.
    let [d, i, m] = random_light(n, 1, [0.3, 0.5, 0.3]);
    // Blobs of complex pixels, so there are borders and pixels off them.
    let alpha: Vec<f32> = (0..n)
        .map(|p| {
            if ((p % w) / 6 + (p / w) / 5) % 3 == 0 && noise(p, 4) < 0.9 {
                1.0
            } else {
                EPS
            }
        })
        .collect();
    let inputs = write_inputs(&dir, (w, h), &d, &i, &alpha, &m, Some(&alpha));
    let expect = eq2(&d, &i, &alpha, &m);

    let (plain, err) = composite(&dir, &inputs, &["--no-fxaa"]);
    assert_eq!(err, "", "a matching mask hash must not warn");
    assert_eq!(rgb(&plain, ""), expect, "eq. (2), bit for bit");
    assert_eq!(
        plain.text_attr("mixmc.tool").as_deref(),
        Some("mixmc-composite")
    );
    assert_eq!(
        plain.text_attr(MASK_HASH_ATTR),
        Some(alpha_hash(w, h, &alpha))
    );
    assert_eq!(plain.text_attr("mixmc.switched").as_deref(), Some("false"));

    let (smooth, _) = composite(&dir, &inputs, &[]);
    let borders = mask_borders(&alpha, w, h);
    let smooth = rgb(&smooth, "");
    let (mut on, mut changed) = (0, 0);
    for p in 0..n {
        if borders[p] {
            on += 1;
            changed += (smooth[p] != expect[p]) as usize;
        } else {
            assert_eq!(
                smooth[p],
                expect[p],
                "FXAA changed pixel ({}, {}) off the mask's borders",
                p % w,
                p / w
            );
        }
    }
    assert!(
        on > 50 && on < n - 50,
        "test mask should have borders and interiors: {on}"
    );
    assert!(changed > 0, "FXAA changed no border pixel of a noisy image");
}

#[test]
fn one_thread_and_all_give_the_same_image() {
    // Large enough that eq. (2), the borders and FXAA split into parallel parts.
    let dir = temp_dir("threads");
    let (w, h) = (512, 320);
    assert!(w * h > 2 * mixmc::PIXEL_CHUNK);
    let n = w * h;
    let [d, i, m] = random_light(n, 5, [0.3, 0.5, 0.3]);
    let alpha: Vec<f32> = (0..n)
        .map(|p| if noise(p, 8) < 0.3 { 1.0 } else { EPS })
        .collect();
    let inputs = write_inputs(&dir, (w, h), &d, &i, &alpha, &m, Some(&alpha));
    let (one, _) = composite(&dir, &inputs, &["--threads", "1"]);
    let (all, _) = composite(&dir, &inputs, &[]);
    assert!(one.float_attr("mixmc.fxaa_pixels").unwrap() > 0.0);
    assert_eq!(rgb(&one, ""), rgb(&all, ""));
}

#[test]
fn uniform_epsilon_is_d_plus_nine_tenths_i_plus_mcmc() {
    let dir = temp_dir("eps");
    let (w, h) = (12, 10);
    let n = w * h;
    let [d, i, m] = random_light(n, 5, [1.0, 4.0, 0.5]);
    let alpha = vec![EPS; n];
    let inputs = write_inputs(&dir, (w, h), &d, &i, &alpha, &m, Some(&alpha));
    let (out, _) = composite(&dir, &inputs, &[]);
    let expect: Vec<[f32; 3]> = (0..n)
        .map(|p| std::array::from_fn(|c| d[p][c] + i[p][c] * 0.9 + m[p][c]))
        .collect();
    assert_eq!(rgb(&out, ""), expect);
    assert_eq!(out.float_attr("mixmc.complex_fraction"), Some(0.0));
}

/// A disc rendered with one sample per pixel centre, or its 16×16-supersampled coverage.
fn disc_coverage(w: usize, h: usize, samples: usize) -> Vec<f32> {
    let (cx, cy, r) = (w as f32 * 0.47, h as f32 * 0.53, h as f32 * 0.33);
    (0..w * h)
        .map(|p| {
            let (x, y) = ((p % w) as f32, (p / w) as f32);
            let inside = (0..samples * samples)
                .filter(|k| {
                    let sx = x + ((k % samples) as f32 + 0.5) / samples as f32 - cx;
                    let sy = y + ((k / samples) as f32 + 0.5) / samples as f32 - cy;
                    sx * sx + sy * sy < r * r
                })
                .count();
            inside as f32 / (samples * samples) as f32
        })
        .collect()
}

#[test]
fn fxaa_reduces_the_error_of_an_aliased_seam() {
    // A bright disc rendered by MCMC (its pixels complex) on a dim OMC background: the seam along
    // the mask border is a hard aliased edge.
    let dir = temp_dir("seam");
    let (w, h) = (64, 48);
    let aliased = disc_coverage(w, h, 1);
    let truth = disc_coverage(w, h, 16);
    let d = vec![[0.05, 0.05, 0.05]; w * h];
    let i_omc = vec![[0.0; 3]; w * h];
    let alpha: Vec<f32> = aliased
        .iter()
        .map(|c| if *c > 0.5 { 1.0 } else { EPS })
        .collect();
    let m: Vec<[f32; 3]> = aliased
        .iter()
        .map(|c| [0.9 * c, 0.7 * c, 0.5 * c])
        .collect();
    let reference: Vec<[f32; 3]> = truth
        .iter()
        .map(|c| [0.05 + 0.9 * c, 0.05 + 0.7 * c, 0.05 + 0.5 * c])
        .collect();
    let inputs = write_inputs(&dir, (w, h), &d, &i_omc, &alpha, &m, Some(&alpha));
    let err = |img: &[[f32; 3]]| -> f64 {
        img.iter()
            .zip(&reference)
            .map(|(a, b)| (0..3).map(|c| ((a[c] - b[c]) as f64).powi(2)).sum::<f64>())
            .sum()
    };
    let (plain, _) = composite(&dir, &inputs, &["--no-fxaa"]);
    let (smooth, _) = composite(&dir, &inputs, &[]);
    let (before, after) = (err(&rgb(&plain, "")), err(&rgb(&smooth, "")));
    println!("seam squared error: {before:.4} without FXAA, {after:.4} with");
    assert!(after < 0.6 * before, "FXAA: {before} → {after}");
    assert!(smooth.float_attr("mixmc.fxaa_pixels").unwrap() > 0.0);
}

#[test]
fn switch_renders_mcmc_only_unless_the_mcmc_was_rendered_with_the_mask() {
    let dir = temp_dir("switch");
    let (w, h) = (10, 10);
    let n = w * h;
    let [d, i, m] = random_light(n, 8, [1.0, 1.0, 1.0]);
    // 40% complex: above the default 0.35.
    let alpha: Vec<f32> = (0..n).map(|p| if p < 40 { 1.0 } else { EPS }).collect();
    let d_plus_m: Vec<[f32; 3]> = (0..n)
        .map(|p| std::array::from_fn(|c| d[p][c] + i[p][c] * 0.0 + m[p][c]))
        .collect();

    let unmasked = write_inputs(&dir.join("unmasked"), (w, h), &d, &i, &alpha, &m, None);
    let (out, err) = composite(&dir, &unmasked, &[]);
    assert_eq!(
        err, "",
        "an MCMC image rendered without a mask is what the switch needs"
    );
    assert_eq!(rgb(&out, ""), d_plus_m);
    assert_eq!(out.text_attr("mixmc.switched").as_deref(), Some("true"));

    let masked = write_inputs(
        &dir.join("masked"),
        (w, h),
        &d,
        &i,
        &alpha,
        &m,
        Some(&alpha),
    );
    // Rendered with this very mask, the MCMC image holds α·I only: blended, never switched.
    let (out, err) = composite(&dir, &masked, &["--no-fxaa"]);
    assert_eq!(rgb(&out, ""), eq2(&d, &i, &alpha, &m));
    assert_eq!(out.text_attr("mixmc.switched").as_deref(), Some("false"));
    assert!(
        err.contains("warning") && err.contains("blended by eq. (2)"),
        "{err}"
    );
    // Rendered with another mask: switched, with the warning that it needs an unmasked one.
    let other: Vec<f32> = (0..n).map(|p| if p < 50 { 1.0 } else { EPS }).collect();
    let stale = write_inputs(&dir.join("stale"), (w, h), &d, &i, &alpha, &m, Some(&other));
    let (out, err) = composite(&dir, &stale, &[]);
    assert_eq!(rgb(&out, ""), d_plus_m);
    assert!(
        err.contains("warning") && err.contains("without a mask"),
        "{err}"
    );

    // A mask that already is α ≡ 1 (mixmc-mask switched) used by MMLT is fine.
    let ones = vec![1.0; n];
    let all_ones = write_inputs(&dir.join("ones"), (w, h), &d, &i, &ones, &m, Some(&ones));
    let (out, err) = composite(&dir, &all_ones, &[]);
    assert_eq!((rgb(&out, ""), err), (d_plus_m, String::new()));

    // A higher threshold keeps eq. (2).
    let (out, _) = composite(&dir, &masked, &["--switch", "0.5", "--no-fxaa"]);
    assert_eq!(rgb(&out, ""), eq2(&d, &i, &alpha, &m));
}

#[test]
fn mask_hash_mismatch_warns() {
    let dir = temp_dir("hash");
    let (w, h) = (8, 8);
    let n = w * h;
    let [d, i, m] = random_light(n, 11, [1.0, 1.0, 1.0]);
    let alpha: Vec<f32> = (0..n).map(|p| if p % 9 == 0 { 1.0 } else { EPS }).collect();
    let mut other = alpha.clone();
    other[1] = 1.0;
    let inputs = write_inputs(&dir, (w, h), &d, &i, &alpha, &m, Some(&other));
    let (_, err) = composite(&dir, &inputs, &[]);
    assert!(
        err.contains("warning")
            && err.contains("the-mask.exr")
            && err.contains(&alpha_hash(w, h, &alpha)),
        "{err}"
    );
    let unnamed = write_inputs(&dir.join("unnamed"), (w, h), &d, &i, &alpha, &m, None);
    let (_, err) = composite(&dir, &unnamed, &[]);
    assert!(
        err.contains("warning") && err.contains("names no mask"),
        "{err}"
    );
}

/// The OMC and MCMC images name their scene by path and content hash: the content decides where
/// both carry it (one scene copied to two machines, or one file edited between the renders), the
/// path where not (images made before the hash).
#[test]
fn scenes_are_compared_by_content_where_both_images_carry_it() {
    let dir = temp_dir("scene-hash");
    let (w, h) = (8, 8);
    let n = w * h;
    let [d, i, m] = random_light(n, 12, [1.0, 1.0, 1.0]);
    let alpha: Vec<f32> = (0..n).map(|p| if p % 7 == 0 { 1.0 } else { EPS }).collect();
    let inputs = write_inputs(&dir, (w, h), &d, &i, &alpha, &m, Some(&alpha));
    let retag = |path: &Path, scene: &str, hash: Option<&str>| {
        let mut img = ExrImage::read(path).unwrap();
        img.set_text("mixmc.scene", scene);
        match hash {
            Some(hash) => img.set_text(SCENE_HASH_ATTR, hash),
            None => drop(img.attributes.remove(SCENE_HASH_ATTR)),
        }
        img.write(path, false).unwrap();
    };
    let (one, two) = ("fnv1a64:0123456789abcdef", "fnv1a64:fedcba9876543210");
    let warned = |omc: (&str, Option<&str>), mcmc: (&str, Option<&str>)| {
        retag(&inputs.omc, omc.0, omc.1);
        retag(&inputs.mcmc, mcmc.0, mcmc.1);
        let (out, err) = composite(&dir, &inputs, &["--no-fxaa"]);
        assert_eq!(out.text_attr(SCENE_HASH_ATTR).as_deref(), omc.1);
        err.contains("warning: rendered from scene")
    };
    assert!(!warned(
        ("a/s.json", Some(one)),
        ("/node7/s.json", Some(one))
    ));
    assert!(warned(("s.json", Some(one)), ("s.json", Some(two))));
    assert!(warned(("a/s.json", None), ("/node7/s.json", None)));
    assert!(!warned(("s.json", Some(one)), ("s.json", None)));
}

#[test]
fn size_or_channel_mismatch_names_the_file() {
    let dir = temp_dir("sizes");
    let small = dir.join("small");
    let rgb8 = |n| vec![[0.5f32; 3]; n];
    let good = write_inputs(
        &dir,
        (6, 4),
        &rgb8(24),
        &rgb8(24),
        &[EPS; 24],
        &rgb8(24),
        None,
    );
    let tiny = write_inputs(
        &small,
        (4, 4),
        &rgb8(16),
        &rgb8(16),
        &[EPS; 16],
        &rgb8(16),
        None,
    );
    let out = dir.join("final.exr");
    let args = |omc: &Path, mask: &Path, mcmc: &Path| {
        [
            "--omc",
            path_str(omc),
            "--mask",
            path_str(mask),
            "--mcmc",
            path_str(mcmc),
            "-o",
            path_str(&out),
        ]
        .map(str::to_string)
    };
    let a = args(&good.omc, &tiny.mask, &good.mcmc);
    assert_refused(
        COMPOSITE,
        &a.each_ref().map(String::as_str),
        &[path_str(&tiny.mask), "4×4", "6×4"],
    );
    let a = args(&good.omc, &good.mask, &tiny.mcmc);
    assert_refused(
        COMPOSITE,
        &a.each_ref().map(String::as_str),
        &[path_str(&tiny.mcmc), "4×4"],
    );
    // The mask as the MCMC image: no R,G,B.
    let a = args(&good.omc, &good.mask, &good.mask);
    assert_refused(
        COMPOSITE,
        &a.each_ref().map(String::as_str),
        &[path_str(&good.mask), "missing channel `R`"],
    );
    assert!(!out.exists(), "no output on error");
}
