//! The depth, normal, primitive-id, samples and ambient-occlusion views: the tracer's float
//! output made into a picture with a line saying what its colours mean (the cost view is
//! `views::cost`).

use crate::app::state::ViewMode;
use crate::tracer::heat_map::heat_map;
use crate::tracer::Image;

/// A view's picture: RGBA8 pixels, the heat scale (top, max, mean) where it is a heat map,
/// and what the colours mean otherwise.
pub(crate) struct ViewPicture {
    pub(crate) rgba: Vec<u8>,
    pub(crate) heat: Option<(f32, f32, f32)>,
    pub(crate) note: Option<String>,
}

/// The picture of `image`, traced for `view` (not the colour or cost view: None for those).
pub(crate) fn picture(image: &Image, view: ViewMode) -> Option<ViewPicture> {
    let px = &image.pixels;
    let rgba = |f: &dyn Fn(&[f32; 4]) -> [u8; 3]| {
        px.iter()
            .flat_map(|p| {
                let [r, g, b] = f(p);
                [r, g, b, 255]
            })
            .collect::<Vec<u8>>()
    };
    match view {
        ViewMode::Color | ViewMode::Cost(_) => None,
        ViewMode::Depth => {
            // Misses are -1: black. Hits from white (nearest) to dark grey (farthest).
            let hits = px.iter().map(|p| p[0]).filter(|&d| d >= 0.0);
            let (near, far) = hits.fold((f32::MAX, f32::MIN), |(lo, hi), d| (lo.min(d), hi.max(d)));
            let span = (far - near).max(1e-6);
            let shade = |p: &[f32; 4]| {
                if p[0] < 0.0 {
                    [0; 3]
                } else {
                    [(255.0 - 215.0 * (p[0] - near) / span).round() as u8; 3]
                }
            };
            let note = if near <= far {
                format!("distance {near:.2} (white) to {far:.2} (grey); black: no hit")
            } else {
                "no hit: nothing in view".into()
            };
            Some(ViewPicture { rgba: rgba(&shade), heat: None, note: Some(note) })
        }
        ViewMode::Normal => {
            let shade = |p: &[f32; 4]| {
                [0, 1, 2].map(|i| ((p[i] * 0.5 + 0.5).clamp(0.0, 1.0) * 255.0).round() as u8)
            };
            Some(ViewPicture {
                rgba: rgba(&shade),
                heat: None,
                note: Some("normal x, y, z as red, green, blue (0 = mid grey)".into()),
            })
        }
        ViewMode::PrimId => {
            let shade = |p: &[f32; 4]| if p[0] < 0.0 { [0; 3] } else { id_color(p[0] as u32) };
            let mut ids: Vec<u32> =
                px.iter().filter(|p| p[0] >= 0.0).map(|p| p[0] as u32).collect();
            ids.sort_unstable();
            ids.dedup();
            Some(ViewPicture {
                rgba: rgba(&shade),
                heat: None,
                note: Some(format!(
                    "{} triangles in view, a colour each; black: no hit",
                    ids.len()
                )),
            })
        }
        ViewMode::Samples => {
            let values: Vec<f32> = px.iter().map(|p| p[0]).collect();
            let map = heat_map(&values);
            Some(ViewPicture {
                rgba: map.rgba,
                heat: Some((map.scale_max, map.max, map.mean)),
                note: None,
            })
        }
        ViewMode::Ao => {
            // Grey over a dark blue where nothing was hit, blended by the pixel's coverage
            // (alpha: 0 on a miss, between at jittered edges) so a miss is not "enclosed".
            let shade = |p: &[f32; 4]| {
                let cover = p[3].clamp(0.0, 1.0);
                AO_MISS.map(|m| {
                    ((p[0].clamp(0.0, 1.0) * 255.0) * cover + m as f32 * (1.0 - cover)).round()
                        as u8
                })
            };
            let note = "ambient occlusion: white = open, black = enclosed within the AO radius; blue: no hit";
            Some(ViewPicture { rgba: rgba(&shade), heat: None, note: Some(note.into()) })
        }
    }
}

/// The AO view's colour where the camera ray hits nothing.
const AO_MISS: [u8; 3] = [24, 32, 64];

/// A bright colour for a triangle index: neighbouring ids get unrelated colours.
fn id_color(id: u32) -> [u8; 3] {
    let h = id.wrapping_mul(0x9E37_79B9).rotate_left(13).wrapping_mul(0x85EB_CA6B);
    [(h >> 24) as u8 | 0x40, (h >> 16) as u8 | 0x40, (h >> 8) as u8 | 0x40]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(values: &[[f32; 4]]) -> Image {
        let mut img = Image::new(values.len() as u32, 1);
        img.pixels.copy_from_slice(values);
        img
    }

    #[test]
    fn depth_runs_from_white_near_to_grey_far_and_misses_are_black() {
        let p = picture(&image(&[[1.0; 4], [3.0; 4], [-1.0; 4]]), ViewMode::Depth).unwrap();
        assert_eq!(&p.rgba[0..3], &[255; 3]);
        assert_eq!(&p.rgba[4..7], &[40; 3]);
        assert_eq!(&p.rgba[8..11], &[0; 3]);
        assert!(p.note.unwrap().contains("1.00 (white) to 3.00"));
    }

    #[test]
    fn normals_map_to_colours_and_ids_count_triangles() {
        let n = picture(&image(&[[1.0, 0.0, -1.0, 1.0]]), ViewMode::Normal).unwrap();
        assert_eq!(&n.rgba[0..3], &[255, 128, 0]);
        let ids =
            picture(&image(&[[7.0; 4], [7.0; 4], [8.0; 4], [-1.0; 4]]), ViewMode::PrimId).unwrap();
        assert_eq!(&ids.rgba[0..4], &ids.rgba[4..8], "one triangle, one colour");
        assert_ne!(&ids.rgba[0..4], &ids.rgba[8..12], "neighbouring ids differ");
        assert_eq!(&ids.rgba[12..15], &[0; 3]);
        assert!(ids.note.unwrap().starts_with("2 triangles"));
        assert!(picture(&image(&[[1.0; 4]]), ViewMode::Color).is_none());
    }

    #[test]
    fn ao_is_grey_by_openness_and_misses_are_blue() {
        let p = picture(
            &image(&[[1.0, 1.0, 1.0, 1.0], [0.25, 0.25, 0.25, 1.0], [1.0, 1.0, 1.0, 0.0]]),
            ViewMode::Ao,
        )
        .unwrap();
        assert_eq!(&p.rgba[0..3], &[255; 3]);
        assert_eq!(&p.rgba[4..7], &[64; 3]);
        assert_eq!(&p.rgba[8..11], &AO_MISS);
        assert!(p.note.unwrap().contains("ambient occlusion"));
    }
}
