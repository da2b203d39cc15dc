//! Random meshes for the BVH tests: a seeded source and triangle soups.

use glam::Vec3;
use meshtracer::geometry::Aabb;

/// xorshift64: a seeded, dependency-free random source.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    /// Uniform in [0, 1).
    pub fn f(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f()
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    pub fn vec_in(&mut self, b: &Aabb) -> Vec3 {
        Vec3::new(self.range(b.min.x, b.max.x), self.range(b.min.y, b.max.y), self.range(b.min.z, b.max.z))
    }
    pub fn unit(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(self.range(-1.0, 1.0), self.range(-1.0, 1.0), self.range(-1.0, 1.0));
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }
}

/// `n` random triangles of about `size` scattered in the cube of half-width `extent`.
pub fn soup(rng: &mut Rng, n: usize, extent: f32, size: f32) -> Vec<[Vec3; 3]> {
    let b = Aabb { min: Vec3::splat(-extent), max: Vec3::splat(extent) };
    (0..n)
        .map(|_| {
            let c = rng.vec_in(&b);
            [c + rng.unit() * size, c + rng.unit() * size, c + rng.unit() * size]
        })
        .collect()
}
