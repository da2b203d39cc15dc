//! Blinn–Phong shading and the mirror-bounce blend (paper 3.3 steps 3 and 6), the CPU
//! twin of `shaders/shade.glsl`; and the AO view's ray directions.

use glam::Vec3;

/// A material as the tracers read it (see `packed::GpuMaterial`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingMaterial {
    pub diffuse: Vec3,
    pub specular: Vec3,
    pub shininess: f32,
    pub mirror: f32,
}

/// Blinn–Phong from one point light: `Kd*ambient + light*(Kd*max(N.L,0) + Ks*max(N.H,0)^Ns)`,
/// the diffuse and specular terms only where `lit` (see [`light_reaches`]); no shadow rays
/// against the rest of the scene (as the paper). `n` is the shading normal facing the viewer.
#[allow(clippy::too_many_arguments)]
pub fn blinn_phong(
    m: &ShadingMaterial,
    kd: Vec3,
    l: Vec3,
    n: Vec3,
    lit: bool,
    to_eye: Vec3,
    light_color: Vec3,
    ambient: f32,
) -> Vec3 {
    let ndl = if lit { n.dot(l).max(0.0) } else { 0.0 };
    let spec = if ndl > 0.0 {
        let h = (l + to_eye).normalize();
        n.dot(h).max(0.0).powf(m.shininess)
    } else {
        0.0
    };
    kd * ambient + light_color * (kd * ndl + m.specular * spec)
}

/// An AO ray's direction from two uniform numbers in [0, 1): cosine-weighted over the
/// hemisphere around the shading normal `ns` (unit), mirrored back above the triangle
/// (geometric normal `ng`, facing the viewer) where a smooth normal tips it under. The twin
/// of the loop body of `ambient_occlusion` in `shaders/trace.glsl`, term for term.
pub fn ao_direction(ns: Vec3, ng: Vec3, u1: f32, u2: f32) -> Vec3 {
    // A frame around ns without a branch on its direction (Duff et al. 2017).
    let sgn = if ns.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sgn + ns.z);
    let b = ns.x * ns.y * a;
    let tangent = Vec3::new(1.0 + sgn * ns.x * ns.x * a, sgn * b, -sgn * ns.x);
    let bitangent = Vec3::new(b, sgn + ns.y * ns.y * a, -ns.y);
    let r = u1.sqrt();
    let (sin, cos) = (std::f32::consts::TAU * u2).sin_cos();
    let mut d =
        (tangent * (r * cos) + bitangent * (r * sin) + ns * (1.0 - u1).max(0.0).sqrt()).normalize();
    let below = d.dot(ng);
    if below < 0.0 {
        d -= 2.0 * below * ng;
    }
    d
}

/// The hit triangle as a smoothly shaded hit sees it: corners relative to the hit point's
/// barycentrics `(u, v)`, edges and the corner normals (object space, flipped to the
/// viewer's side of the triangle, not necessarily unit length).
#[derive(Clone, Copy, Debug)]
pub struct SmoothTriangle {
    pub u: f32,
    pub v: f32,
    pub e1: Vec3,
    pub e2: Vec3,
    pub normals: [Vec3; 3],
}

impl SmoothTriangle {
    /// Hanika, "Hacking the shadow terminator" (Ray Tracing Gems II, ch. 4): the hit point
    /// moved out to the tangent planes of the three corners (each corner's plane through it
    /// with its normal; only the part of the projection that moves outwards), blended with
    /// the barycentrics. Returned as the offset from the hit point, in object space. The
    /// shader's `terminator_offset`.
    pub fn terminator_offset(&self) -> Vec3 {
        let (u, v) = (self.u, self.v);
        let w = 1.0 - u - v;
        // The hit point relative to each corner.
        let rel = [
            self.e1 * u + self.e2 * v,
            self.e1 * (u - 1.0) + self.e2 * v,
            self.e1 * u + self.e2 * (v - 1.0),
        ];
        let weights = [w, u, v];
        let mut offset = Vec3::ZERO;
        for k in 0..3 {
            let n = self.normals[k];
            if n.length_squared() > 1e-12 {
                let n = n.normalize();
                let below = rel[k].dot(n).min(0.0);
                offset -= n * (below * weights[k]);
            }
        }
        offset
    }

    /// Whether the segment from the offset hit point `hit + offset` to the light (`to_light`,
    /// object space, the light at parameter 1) passes through the triangle itself: the
    /// self-shadow test of a smoothly shaded hit. Möller–Trumbore from the triangle's first
    /// corner; a crossing behind the origin counts too (an origin below the triangle).
    pub fn shadows_itself(&self, offset: Vec3, to_light: Vec3) -> bool {
        let p = to_light.cross(self.e2);
        let det = self.e1.dot(p);
        if det.abs() < 1e-12 {
            return false;
        }
        let inv = 1.0 / det;
        let tv = self.e1 * self.u + self.e2 * self.v + offset;
        let a = tv.dot(p) * inv;
        if !(0.0..=1.0).contains(&a) {
            return false;
        }
        let q = tv.cross(self.e1);
        let b = to_light.dot(q) * inv;
        if b < 0.0 || a + b > 1.0 {
            return false;
        }
        self.e2.dot(q) * inv < 1.0
    }
}

/// Whether the point light reaches a hit. The tracers trace no shadow rays (the paper), so
/// the only occluder is the hit triangle itself: light behind its plane (`ng`, facing the
/// viewer) is blocked, so smooth normals cannot leak it through silhouettes. For a smoothly
/// shaded hit that the shading normal `ns` says is lit, that self-shadow test starts from
/// Hanika's offset point instead, so the terminator follows the smooth normals rather than
/// the flat triangles (no stair steps on low-polygon meshes). Everything in the mesh's
/// space: `l` the direction to the light (not normalised), `light` its position and `p` the
/// hit. The shader's `light_reaches`.
pub fn light_reaches(
    l: Vec3,
    ng: Vec3,
    ns: Vec3,
    smooth: Option<&SmoothTriangle>,
    p: Vec3,
    light: Vec3,
) -> bool {
    if ng.dot(l) > 0.0 {
        return true;
    }
    let Some(tri) = smooth else { return false };
    if ns.dot(l) <= 0.0 {
        return false;
    }
    let offset = tri.terminator_offset();
    !tri.shadows_itself(offset, light - (p + offset))
}

/// Mirror direction of `d` about the unit normal `n`.
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ao_directions_are_unit_above_the_surface_and_cosine_weighted() {
        let ng = Vec3::new(0.0, 0.6, 0.8);
        for ns in [ng, Vec3::new(0.3, 0.2, -0.9).normalize(), Vec3::Z, Vec3::NEG_Z] {
            let (mut mean_cos, n) = (0.0, 64);
            for i in 0..n {
                for j in 0..n {
                    let d = ao_direction(
                        ns,
                        ng,
                        (i as f32 + 0.5) / n as f32,
                        (j as f32 + 0.5) / n as f32,
                    );
                    assert!((d.length() - 1.0).abs() < 1e-5 && d.dot(ng) >= 0.0, "{ns} {d}");
                    mean_cos += d.dot(ns) / (n * n) as f32;
                }
            }
            // E[cos] = 2/3 for cosine-weighted directions (mirroring changes some for a tipped ns).
            if ns == ng {
                assert!((mean_cos - 2.0 / 3.0).abs() < 1e-3, "{mean_cos}");
            }
        }
    }

    #[test]
    fn head_on_light_gives_diffuse_plus_full_specular() {
        let m = ShadingMaterial {
            diffuse: Vec3::splat(0.5),
            specular: Vec3::splat(0.25),
            shininess: 10.0,
            mirror: 0.0,
        };
        // Light and eye straight above a surface facing up: N.L = N.H = 1.
        let c = blinn_phong(&m, m.diffuse, Vec3::Y, Vec3::Y, true, Vec3::Y, Vec3::ONE, 0.1);
        assert!((c - Vec3::splat(0.05 + 0.5 + 0.25)).length() < 1e-6);
        // Light behind the surface: ambient only.
        let lit = light_reaches(-Vec3::Y, Vec3::Y, Vec3::Y, None, Vec3::ZERO, -Vec3::Y);
        let c = blinn_phong(&m, m.diffuse, -Vec3::Y, Vec3::Y, lit, Vec3::Y, Vec3::ONE, 0.1);
        assert!((c - Vec3::splat(0.05)).length() < 1e-6);
        // A smooth normal tilted towards a light that is behind the geometric surface: no leak.
        let tilted = Vec3::new(0.0, 0.2, 1.0).normalize();
        let light = Vec3::new(0.0, 3.0, -0.1);
        let l = light.normalize();
        assert!(!light_reaches(l, Vec3::Z, tilted, None, Vec3::ZERO, light));
        let c = blinn_phong(&m, m.diffuse, l, tilted, false, Vec3::Z, Vec3::ONE, 0.1);
        assert!((c - Vec3::splat(0.05)).length() < 1e-6);
    }

    /// A triangle of a unit sphere with its radial corner normals.
    fn sphere_patch() -> ([Vec3; 3], SmoothTriangle) {
        let corners =
            [Vec3::new(1.0, 0.2, 0.1), Vec3::new(0.3, 1.0, 0.0), Vec3::new(0.2, 0.1, 1.0)]
                .map(Vec3::normalize);
        let (e1, e2) = (corners[1] - corners[0], corners[2] - corners[0]);
        (corners, SmoothTriangle { u: 1.0 / 3.0, v: 1.0 / 3.0, e1, e2, normals: corners })
    }

    #[test]
    fn terminator_offset_lifts_the_hit_towards_the_smooth_surface() {
        let (corners, tri) = sphere_patch();
        let centre = (corners[0] + corners[1] + corners[2]) / 3.0;
        let lifted = centre + tri.terminator_offset();
        let ng = tri.e1.cross(tri.e2).normalize();
        assert!(tri.terminator_offset().dot(ng) > 0.0, "moved outwards");
        assert!(
            (lifted.length() - 1.0).abs() < (centre.length() - 1.0).abs() * 0.5,
            "closer to the sphere: {} vs {}",
            lifted.length(),
            centre.length()
        );
        // At a corner the hit is on that corner's tangent plane: no offset.
        for (u, v) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)] {
            assert!(SmoothTriangle { u, v, ..tri }.terminator_offset().length() < 1e-6);
        }
        // Corner normals equal to the face normal (a flat region): no offset.
        let flat = SmoothTriangle { normals: [ng; 3], ..tri };
        assert!(flat.terminator_offset().length() < 1e-6);
        // Only outwards: corner normals leaning so that the hit is above their planes.
        let concave =
            SmoothTriangle { normals: corners.map(|c| (2.0 * ng - c).normalize()), ..tri };
        assert_eq!(concave.terminator_offset(), Vec3::ZERO);
    }

    #[test]
    fn smooth_hits_near_the_terminator_see_the_light_past_their_triangle() {
        let (corners, tri) = sphere_patch();
        let tri = SmoothTriangle { u: 0.6, v: 0.2, ..tri };
        let ng = tri.e1.cross(tri.e2).normalize();
        let p = corners[0] + tri.e1 * tri.u + tri.e2 * tri.v;
        let ns = (corners[0] * 0.2 + corners[1] * 0.6 + corners[2] * 0.2).normalize();
        // A far light just below the triangle's plane, on the side the smooth normal leans to.
        let along = ns.reject_from(ng).normalize();
        let light = p + (along - ng * 0.02).normalize() * 50.0;
        let l = (light - p).normalize();
        assert!(ng.dot(l) < 0.0 && ns.dot(l) > 0.0, "set-up: between the two planes");
        assert!(
            !light_reaches(l, ng, ns, None, p, light),
            "flat shading: blocked by the triangle's plane"
        );
        assert!(
            light_reaches(l, ng, ns, Some(&tri), p, light),
            "smooth shading: the offset point sees past the triangle"
        );
        // The same instance scaled by 3: the offset is in object space.
        assert!(light_reaches(l, ng, ns, Some(&tri), p, p + (light - p) * 3.0));
        // Corner normals equal to the face normal (a flat region): the flat test, blocked.
        let flat = SmoothTriangle { normals: [ng; 3], ..tri };
        assert!(!light_reaches(l, ng, ns, Some(&flat), p, light));
        // Light well below the plane: the triangle blocks it from the offset point too (with
        // a shading normal leaning far enough to ask).
        let light = p + (along - ng * 3.0).normalize() * 50.0;
        let l = (light - p).normalize();
        let leaning = (ns + along * 4.0).normalize();
        assert!(leaning.dot(l) > 0.0);
        assert!(!light_reaches(l, ng, leaning, Some(&tri), p, light));
    }

    #[test]
    fn reflect_flips_normal_component() {
        assert_eq!(reflect(Vec3::new(1.0, -1.0, 0.0), Vec3::Y), Vec3::new(1.0, 1.0, 0.0));
    }
}
