//! Render space: the coordinates both twins trace in. A scene loaded
//! from a file (or built in) is translated, in f64, so that its camera
//! sits at (or, with 3-D checkers, near) the origin, and only then rounded
//! to f32 (pbrt-v4's camera-world rendering space does the same). Near the
//! camera, where the image's detail is, f32 then resolves what the file's
//! numbers say however far from the world's origin they lie.
//!
//! The 3-D checker is a pattern fixed in world space (the sign of
//! `sin(s·x)·sin(s·y)·sin(s·z)`), and both twins evaluate it at
//! render-space points. So the origin is moved from the camera to the
//! nearest point of the lattice of the checkers' half periods (π/s on
//! each axis, common to every checker of the scene): there a checker's
//! sines are the world's, each factor's sign turned once per half period
//! the origin lies away, and a checker whose product turns an odd number
//! of times has its `even` and `odd` swapped. The pattern is then the
//! world's exactly, at no cost to either twin.

use crate::texture::Texture;
use glam::DVec3;
use std::f64::consts::PI;

/// Where a [`super::SceneBuilder`] puts its scene's render-space origin.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum RenderOrigin {
    /// At the world's origin: the builder's coordinates are traced as
    /// given (scenes built in code by tests, which aim rays in them).
    #[default]
    World,
    /// At the camera's `look_from` (on the checkers' lattice): every scene
    /// file and built-in scene.
    Camera,
    /// Near this world point (on the checkers' lattice): a scene file's
    /// `render_origin`, which pins render space whatever its camera.
    At(DVec3),
}

/// The checkers' common lattice: the origin is `steps · π·2^-exponent / g`
/// on each axis.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Lattice {
    exponent: i32,
    g: u128,
    /// Whether the steps over the three axes add up to an odd number.
    odd_steps: bool,
}

/// A scene's render space: world coordinates minus [`RenderSpace::origin`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderSpace {
    origin: DVec3,
    lattice: Option<Lattice>,
}

/// `|s| = m · 2^e` with `m` odd; `None` for 0 and non-finite values.
fn odd_mantissa(s: f32) -> Option<(u128, i32)> {
    let s = s.abs();
    if s == 0.0 || !s.is_finite() {
        return None;
    }
    let bits = s.to_bits();
    let (raw_exp, frac) = ((bits >> 23) as i32, bits & 0x7f_ffff);
    let (mut m, mut e) = if raw_exp == 0 {
        (frac as u128, -149)
    } else {
        ((frac | 0x80_0000) as u128, raw_exp - 150)
    };
    let z = m.trailing_zeros();
    m >>= z;
    e += z as i32;
    Some((m, e))
}

fn gcd(mut a: u128, mut b: u128) -> u128 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// The largest shift between checker scales' exponents the lattice is
/// computed for: beyond it (scales 2^100 apart) the scene keeps the
/// world's origin.
const MAX_SHIFT: i32 = 100;

/// Half periods of a checker of scale `m·2^e` in one lattice step, if whole.
fn half_periods(m: u128, e: i32, exponent: i32, g: u128) -> Option<u128> {
    let shift = e.checked_sub(exponent)?;
    if !(0..=MAX_SHIFT).contains(&shift) {
        return None;
    }
    let n = m << shift;
    (n % g == 0).then_some(n / g)
}

impl RenderSpace {
    /// The world's own coordinates (origin zero).
    pub const WORLD: RenderSpace = RenderSpace {
        origin: DVec3::ZERO,
        lattice: None,
    };

    /// Render space with its origin at `near` moved to the lattice of the
    /// checkers among `textures`; the world's where no such lattice point
    /// can be resolved (checker scales 2^100 apart, or half periods below
    /// f64's resolution at `near`).
    pub fn near(near: DVec3, textures: &[Texture]) -> RenderSpace {
        if !near.is_finite() {
            return Self::WORLD;
        }
        let scales: Vec<(u128, i32)> = textures
            .iter()
            .filter_map(|t| match *t {
                Texture::Checker { scale, .. } => odd_mantissa(scale),
                _ => None,
            })
            .collect();
        let Some(exponent) = scales.iter().map(|&(_, e)| e).min() else {
            return RenderSpace {
                origin: near,
                lattice: None,
            };
        };
        let mut g = 0;
        for &(m, e) in &scales {
            match half_periods(m, e, exponent, 1) {
                Some(n) => g = gcd(g, n),
                None => return Self::WORLD,
            }
        }
        let step = PI / g as f64 * 2f64.powi(-exponent);
        let steps = (near / step).round();
        if !(step.is_finite() && step > 0.0) || steps.abs().max_element() > 2f64.powi(52) {
            return Self::WORLD;
        }
        let odd = |k: f64| k.rem_euclid(2.0) == 1.0;
        RenderSpace {
            origin: steps * step,
            lattice: Some(Lattice {
                exponent,
                g,
                odd_steps: odd(steps.x) ^ odd(steps.y) ^ odd(steps.z),
            }),
        }
    }

    /// World coordinates of render space's origin.
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// Whether a checker of scale `scale` has its `even` and `odd` swapped
    /// in render space (the product of its sines changes sign between a
    /// world point and its render-space point); `None` where the origin
    /// does not lie on the checker's lattice, so no swap makes its
    /// render-space pattern the world's.
    pub fn checker_swap(&self, scale: f32) -> Option<bool> {
        if self.origin == DVec3::ZERO {
            return Some(false);
        }
        let Some((m, e)) = odd_mantissa(scale) else {
            // sin(0·x) is 0 everywhere: always `even`.
            return scale.is_finite().then_some(false);
        };
        let l = self.lattice?;
        let n = half_periods(m, e, l.exponent, l.g)?;
        Some(n % 2 == 1 && l.odd_steps)
    }

    /// `texture` as render space evaluates it (a checker's swap; other
    /// textures are unchanged); the same map takes it back. `None`: a
    /// checker render space cannot hold ([`RenderSpace::checker_swap`]).
    pub fn texture(&self, texture: Texture) -> Option<Texture> {
        match texture {
            Texture::Checker { scale, even, odd } => {
                let swap = self.checker_swap(scale)?;
                Some(if swap {
                    Texture::Checker {
                        scale,
                        even: odd,
                        odd: even,
                    }
                } else {
                    texture
                })
            }
            other => Some(other),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture::evaluate_texture;
    use glam::{Vec2, Vec3};

    fn checkers(scales: &[f32]) -> Vec<Texture> {
        let mut t = vec![Texture::Constant(Vec3::ZERO), Texture::Constant(Vec3::ONE)];
        t.extend(scales.iter().map(|&scale| Texture::Checker {
            scale,
            even: 0,
            odd: 1,
        }));
        t
    }

    #[test]
    fn without_checkers_the_origin_is_the_point_itself() {
        let p = DVec3::new(12000.3, -9000.7, 1e6 + 0.1);
        let space = RenderSpace::near(p, &[Texture::Constant(Vec3::ONE)]);
        assert_eq!(space.origin(), p);
    }

    /// The pattern at render-space points (f64 arithmetic, so that only
    /// the lattice is under test) is the world's pattern.
    #[test]
    fn checkers_read_the_world_pattern_in_render_space() {
        for scales in [&[3.0f32, 6.0][..], &[4.0], &[0.3, 0.6, -1.2], &[5.0, 0.0]] {
            let world = checkers(scales);
            for near in [
                DVec3::new(0.0, 2.5, 6.0),
                DVec3::new(12000.0, 9000.6, -15997.4),
                DVec3::new(-3.3e5, 7.0e4, 1.0e5),
            ] {
                let space = RenderSpace::near(near, &world);
                assert!((space.origin() - near).abs().max_element() < 2.0 * PI / 0.3);
                let rendered: Vec<Texture> =
                    world.iter().map(|&t| space.texture(t).unwrap()).collect();
                let pick = |textures: &[Texture], id: u32, p: DVec3| {
                    let Texture::Checker { scale, even, odd } = textures[id as usize] else {
                        unreachable!()
                    };
                    let s = scale as f64;
                    let sines = (s * p.x).sin() * (s * p.y).sin() * (s * p.z).sin();
                    if sines < 0.0 {
                        odd
                    } else {
                        even
                    }
                };
                let mut rng = 0x9e37_79b9_7f4a_7c15u64;
                let mut next = || {
                    rng ^= rng << 13;
                    rng ^= rng >> 7;
                    rng ^= rng << 17;
                    (rng >> 11) as f64 / (1u64 << 53) as f64 * 20.0 - 10.0
                };
                for _ in 0..2000 {
                    let w = near + DVec3::new(next(), next(), next());
                    let p = w - space.origin();
                    for id in 2..world.len() as u32 {
                        assert_eq!(
                            pick(&world, id, w),
                            pick(&rendered, id, p),
                            "{scales:?} near {near}: checker {id} at {w}"
                        );
                    }
                    // As the twins evaluate it: f32 at the render-space
                    // point (away from the boundaries, which f32 moves).
                    let s = scales[0] as f64;
                    let margin = [w.x, w.y, w.z]
                        .map(|c| (s * c).sin().abs())
                        .into_iter()
                        .fold(f64::INFINITY, f64::min);
                    if margin > 1e-3 && p.abs().max_element() < 30.0 {
                        let want = if pick(&world, 2, w) == 0 {
                            Vec3::ZERO
                        } else {
                            Vec3::ONE
                        };
                        let got = evaluate_texture(
                            &rendered,
                            &[],
                            2,
                            p.as_vec3(),
                            [Vec2::ZERO; 2],
                            Vec3::ONE,
                        );
                        assert_eq!(got, want, "{scales:?} near {near}: f32 at {p}");
                    }
                }
            }
        }
    }

    #[test]
    fn a_checker_off_the_lattice_is_refused() {
        let space = RenderSpace::near(DVec3::new(100.0, 0.0, 0.0), &checkers(&[4.0]));
        assert_eq!(space.checker_swap(4.0).map(|_| ()), Some(()));
        assert_eq!(space.checker_swap(8.0).map(|_| ()), Some(()));
        assert_eq!(space.checker_swap(3.0), None);
        assert_eq!(RenderSpace::WORLD.checker_swap(3.0), Some(false));
        // No checker at all: the origin is the point, and a checker added
        // later does not fit.
        let bare = RenderSpace::near(DVec3::new(1.5, 0.0, 0.0), &[]);
        assert_eq!(bare.checker_swap(2.0), None);
    }
}
