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
        Vec3::new(
            self.range(b.min.x, b.max.x),
            self.range(b.min.y, b.max.y),
            self.range(b.min.z, b.max.z),
        )
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

/// An architectural scene, the case the build's triangle cutting is for: a room of a few
/// huge triangles (floor, walls, ceiling and a slanted roof, in two triangles each) around
/// `n` small random triangles, so that the huge ones have boxes far above the median.
#[allow(dead_code)]
pub fn room(rng: &mut Rng, n: usize) -> Vec<[Vec3; 3]> {
    let quad = |a: Vec3, b: Vec3, c: Vec3, d: Vec3| [[a, b, c], [a, c, d]];
    let (lo, hi) = (Vec3::new(-10.0, 0.0, -6.0), Vec3::new(10.0, 8.0, 6.0));
    let p = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let mut tris: Vec<[Vec3; 3]> = [
        quad(p(lo.x, 0.0, lo.z), p(hi.x, 0.0, lo.z), p(hi.x, 0.0, hi.z), p(lo.x, 0.0, hi.z)),
        quad(p(lo.x, 0.0, lo.z), p(lo.x, hi.y, lo.z), p(hi.x, hi.y, lo.z), p(hi.x, 0.0, lo.z)),
        quad(p(lo.x, 0.0, lo.z), p(lo.x, 0.0, hi.z), p(lo.x, hi.y, hi.z), p(lo.x, hi.y, lo.z)),
        // A roof slanted in two axes: the emptiest boxes.
        quad(
            p(lo.x, hi.y, lo.z),
            p(hi.x, hi.y - 3.0, lo.z),
            p(hi.x, hi.y - 1.0, hi.z),
            p(lo.x, hi.y + 2.0, hi.z),
        ),
    ]
    .into_iter()
    .flatten()
    .collect();
    // Diagonal beams across the room.
    for k in 0..4 {
        let z = lo.z + 2.0 + 2.5 * k as f32;
        tris.push([p(lo.x, 1.0, z), p(hi.x, 6.0, z + 0.5), p(hi.x, 6.2, z + 0.7)]);
    }
    tris.extend(
        soup(rng, n, 4.0, 0.3).into_iter().map(|t| t.map(|v| v + Vec3::new(0.0, 4.0, 0.0))),
    );
    tris
}

/// `count` copies of `bytes`, each with three bytes set to random values (a stand-in for
/// the fuzzer on stable Rust).
#[allow(dead_code)]
pub fn mutations(bytes: &[u8], seed: u64, count: usize) -> Vec<Vec<u8>> {
    let mut rng = Rng(seed);
    (0..count)
        .map(|_| {
            let mut mutated = bytes.to_vec();
            for _ in 0..3 {
                let r = rng.next_u64();
                let at = (r >> 8) as usize % mutated.len();
                mutated[at] = (r >> 40) as u8;
            }
            mutated
        })
        .collect()
}
