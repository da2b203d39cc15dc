//! A pinhole camera that shoots one ray through each pixel centre (paper 3.3, step 1).

use glam::Vec3;

use crate::geometry::Ray;

/// A pinhole camera looking from `position` at `target`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub vfov_deg: f32,
}

/// The camera's frame scaled for ray generation: `dir = forward + x*right + y*up` with
/// `x, y` in [-1, 1] across the image. The GPU gets exactly these vectors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraBasis {
    pub(crate) origin: Vec3,
    pub(crate) forward: Vec3,
    pub(crate) right: Vec3,
    pub(crate) up: Vec3,
}

impl Camera {
    /// The ray-generation basis for an image of `width` x `height` pixels.
    pub(crate) fn basis(&self, width: u32, height: u32) -> CameraBasis {
        let forward = (self.target - self.position).normalize_or(Vec3::NEG_Z);
        let right = forward.cross(self.up).normalize_or(Vec3::X);
        let up = right.cross(forward);
        let half_h = (self.vfov_deg.to_radians() * 0.5).tan();
        let aspect = width as f32 / height.max(1) as f32;
        CameraBasis {
            origin: self.position,
            forward,
            right: right * half_h * aspect,
            up: up * half_h,
        }
    }

    /// The same view direction, moved towards the target until a sphere of `radius` around
    /// the target overfills the frame's height by `overfill` (1 = just touching its edges).
    pub(crate) fn framing(&self, radius: f32, overfill: f32) -> Camera {
        let dir = (self.position - self.target).normalize_or(Vec3::Z);
        let half_h = (self.vfov_deg.to_radians() * 0.5).tan();
        // The sphere's silhouette spans ±radius/dist·(approx.) of the half-height at distance dist.
        let dist = radius / (half_h * overfill);
        Camera { position: self.target + dir * dist, ..*self }
    }

    /// Slide the eye and the target together across the view: `dx`, `dy` are fractions of
    /// the image's height (right and down positive), so a drag moves the scene with the cursor.
    pub(crate) fn pan(&mut self, dx: f32, dy: f32) {
        let forward = (self.target - self.position).normalize_or(Vec3::NEG_Z);
        let right = forward.cross(self.up).normalize_or(Vec3::X);
        let up = right.cross(forward);
        // The view's height at the target's distance: what one image height spans there.
        let span =
            2.0 * (self.target - self.position).length() * (self.vfov_deg.to_radians() * 0.5).tan();
        let shift = (-dx * right + dy * up) * span;
        self.position += shift;
        self.target += shift;
    }

    /// Orbit the camera around its target by yaw/pitch (radians) and scale its distance.
    pub(crate) fn orbit(&mut self, yaw: f32, pitch: f32, zoom: f32) {
        let offset = self.position - self.target;
        let dist = (offset.length() * zoom).clamp(1e-3, 1e6);
        let cur_pitch = (offset.y / offset.length().max(1e-9)).clamp(-1.0, 1.0).asin();
        let cur_yaw = offset.z.atan2(offset.x);
        let p = (cur_pitch + pitch).clamp(-1.5, 1.5);
        let y = cur_yaw + yaw;
        self.position =
            self.target + dist * Vec3::new(p.cos() * y.cos(), p.sin(), p.cos() * y.sin());
    }
}

impl CameraBasis {
    /// The primary ray through the centre of pixel (`px`, `py`), row 0 at the top.
    pub fn primary_ray(&self, px: u32, py: u32, width: u32, height: u32) -> Ray {
        self.ray_at(px as f32 + 0.5, py as f32 + 0.5, width, height)
    }

    /// Where `point` appears in an image of `width` x `height` pixels (pixel units, row 0 at
    /// the top; outside the image when off screen): the inverse of [`Self::ray_at`]. None
    /// behind the camera.
    pub(crate) fn project(&self, point: Vec3, width: u32, height: u32) -> Option<(f32, f32)> {
        let d = point - self.origin;
        // forward is unit length and right/up are perpendicular to it and to each other.
        let t = d.dot(self.forward);
        if t <= 1e-6 {
            return None;
        }
        let x = d.dot(self.right) / (self.right.length_squared() * t);
        let y = d.dot(self.up) / (self.up.length_squared() * t);
        Some(((x + 1.0) * 0.5 * width as f32, (1.0 - y) * 0.5 * height as f32))
    }

    /// The ray through a point of the image given in pixel units (sub-pixel positions allowed).
    pub(crate) fn ray_at(&self, sx: f32, sy: f32, width: u32, height: u32) -> Ray {
        let x = sx / width as f32 * 2.0 - 1.0;
        let y = 1.0 - sy / height as f32 * 2.0;
        Ray::new(self.origin, (self.forward + x * self.right + y * self.up).normalize())
    }
}

/// A point written `X,Y,Z` (spaces and surrounding parentheses allowed), as `--eye`,
/// `--target` and the panel's camera fields take it; the error names what is wrong.
pub fn parse_point(s: &str) -> Result<Vec3, String> {
    let inner = s.trim().trim_start_matches('(').trim_end_matches(')');
    let parts: Vec<&str> = inner.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!("'{s}' is not X,Y,Z"));
    }
    let mut v = [0.0f32; 3];
    for (slot, p) in v.iter_mut().zip(&parts) {
        let x: f32 = p.parse().map_err(|_| format!("'{p}' is not a number"))?;
        *slot = if x.is_finite() { x } else { return Err(format!("{p} is not a finite number")) };
    }
    Ok(Vec3::from(v))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_inverts_ray_generation() {
        let c = Camera {
            position: Vec3::new(1.0, 2.0, 5.0),
            target: Vec3::new(0.0, 0.5, 0.0),
            up: Vec3::Y,
            vfov_deg: 50.0,
        };
        let b = c.basis(320, 200);
        for (sx, sy) in [(10.5, 20.25), (160.0, 100.0), (300.0, 190.0)] {
            let r = b.ray_at(sx, sy, 320, 200);
            let (px, py) = b.project(r.origin + r.dir * 3.7, 320, 200).unwrap();
            assert!(
                (px - sx).abs() < 1e-3 && (py - sy).abs() < 1e-3,
                "({px}, {py}) for ({sx}, {sy})"
            );
        }
        assert_eq!(
            b.project(c.position - (c.target - c.position), 320, 200),
            None,
            "behind the camera"
        );
    }

    #[test]
    fn panning_moves_eye_and_target_together_across_the_view() {
        let mut c = Camera {
            position: Vec3::new(0.0, 0.0, 4.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 90.0,
        };
        c.pan(0.25, 0.0);
        // Height spanned at distance 4 with a 90° view: 8; a quarter of it, to the left.
        assert!((c.target - Vec3::new(-2.0, 0.0, 0.0)).length() < 1e-5, "{:?}", c.target);
        assert!(
            (c.position - c.target - Vec3::new(0.0, 0.0, 4.0)).length() < 1e-5,
            "the view direction stays"
        );
        c.pan(0.0, 0.5);
        assert!((c.target.y - 4.0).abs() < 1e-5, "dragging down moves the view up: {:?}", c.target);
    }

    #[test]
    fn points_parse_with_or_without_spaces_and_parentheses() {
        assert_eq!(parse_point("1,2,3"), Ok(Vec3::new(1.0, 2.0, 3.0)));
        assert_eq!(parse_point(" (1.5, -2, 3e1) "), Ok(Vec3::new(1.5, -2.0, 30.0)));
        assert_eq!(parse_point("1,2"), Err("'1,2' is not X,Y,Z".into()));
        assert_eq!(parse_point("1,x,3"), Err("'x' is not a number".into()));
        assert_eq!(parse_point("1,inf,3"), Err("inf is not a finite number".into()));
    }

    #[test]
    fn centre_pixel_looks_at_target() {
        let cam = Camera {
            position: Vec3::new(0.0, 0.0, 5.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 60.0,
        };
        let b = cam.basis(3, 3);
        let r = b.primary_ray(1, 1, 3, 3);
        assert!((r.dir - Vec3::NEG_Z).length() < 1e-6);
        // Row 0 is the top of the image: its ray points up.
        assert!(b.primary_ray(1, 0, 3, 3).dir.y > 0.0);
        assert!(b.primary_ray(2, 1, 3, 3).dir.x > 0.0);
    }
}
