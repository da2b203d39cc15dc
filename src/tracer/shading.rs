//! Blinn–Phong shading and the mirror-bounce blend (paper 3.3 steps 3 and 6), the CPU
//! twin of `shaders/shade.glsl`.

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
/// the specular term only on the lit side; no shadow rays (as the paper). `n` is the
/// shading normal, `ng` the geometric one, both facing the viewer: light behind the
/// geometric surface is ignored, so smooth normals cannot leak it through.
#[allow(clippy::too_many_arguments)]
pub fn blinn_phong(m: &ShadingMaterial, kd: Vec3, p: Vec3, n: Vec3, ng: Vec3, to_eye: Vec3, light_pos: Vec3, light_color: Vec3, ambient: f32) -> Vec3 {
    let l = (light_pos - p).normalize();
    let ndl = if ng.dot(l) > 0.0 { n.dot(l).max(0.0) } else { 0.0 };
    let spec = if ndl > 0.0 {
        let h = (l + to_eye).normalize();
        n.dot(h).max(0.0).powf(m.shininess)
    } else {
        0.0
    };
    kd * ambient + light_color * (kd * ndl + m.specular * spec)
}

/// Mirror direction of `d` about the unit normal `n`.
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn head_on_light_gives_diffuse_plus_full_specular() {
        let m = ShadingMaterial { diffuse: Vec3::splat(0.5), specular: Vec3::splat(0.25), shininess: 10.0, mirror: 0.0 };
        // Light and eye straight above a surface facing up: N.L = N.H = 1.
        let c = blinn_phong(&m, m.diffuse, Vec3::ZERO, Vec3::Y, Vec3::Y, Vec3::Y, Vec3::Y * 3.0, Vec3::ONE, 0.1);
        assert!((c - Vec3::splat(0.05 + 0.5 + 0.25)).length() < 1e-6);
        // Light behind the surface: ambient only.
        let c = blinn_phong(&m, m.diffuse, Vec3::ZERO, Vec3::Y, Vec3::Y, Vec3::Y, -Vec3::Y, Vec3::ONE, 0.1);
        assert!((c - Vec3::splat(0.05)).length() < 1e-6);
        // A smooth normal tilted towards a light that is behind the geometric surface: no leak.
        let tilted = Vec3::new(0.0, 0.2, 1.0).normalize();
        let c = blinn_phong(&m, m.diffuse, Vec3::ZERO, tilted, Vec3::Z, Vec3::Z, Vec3::new(0.0, 3.0, -0.1), Vec3::ONE, 0.1);
        assert!((c - Vec3::splat(0.05)).length() < 1e-6);
    }

    #[test]
    fn reflect_flips_normal_component() {
        assert_eq!(reflect(Vec3::new(1.0, -1.0, 0.0), Vec3::Y), Vec3::new(1.0, 1.0, 0.0));
    }
}
