//! The panel's Camera section: the field of view, the eye and target typed in (applied on
//! Enter, following the view while not being edited), and the camera as command-line flags
//! that `render`/`view` take.

use egui::{RichText, Ui};
use glam::Vec3;

use crate::app::panel::section::{Cx, Section};
use crate::app::panel::widgets::{status_line, Status};
use crate::app::state::Params;
use crate::scene::camera::{parse_point, Camera};

/// Narrowest and widest field of view the slider offers, in degrees.
pub(crate) const FOV_RANGE: std::ops::RangeInclusive<f32> = 10.0..=120.0;

/// The section's state: the text in the eye and target fields, and the outcome of the
/// last edit.
#[derive(Default)]
pub(crate) struct CameraPanel {
    eye: String,
    target: String,
    status: Option<Status>,
    /// The camera (eye, target) the status was written for: once the camera moves (a valid
    /// edit, R, a drag), the line no longer says anything true and goes.
    status_camera: (Vec3, Vec3),
}

impl CameraPanel {
    /// Drop the status line once the camera has moved from where it was written.
    fn forget_stale_status(&mut self, camera_now: (Vec3, Vec3)) {
        if self.status.is_some() && self.status_camera != camera_now {
            self.status = None;
        }
    }
}

/// `X,Y,Z` with two decimals: what the fields show and the flags carry.
fn point_text(p: Vec3) -> String {
    format!("{:.2},{:.2},{:.2}", p.x, p.y, p.z)
}

/// `X,Y,Z` in the shortest form that reads back as the same numbers: what the flags carry,
/// so a camera copied as flags is the camera seen, not one rounded to the fields' decimals.
fn exact_point_text(p: Vec3) -> String {
    format!("{},{},{}", p.x, p.y, p.z)
}

/// The camera as `--eye`, `--target` and `--fov` flags.
pub(crate) fn camera_flags(c: &Camera) -> String {
    format!(
        "--eye {} --target {} --fov {}",
        exact_point_text(c.position),
        exact_point_text(c.target),
        c.vfov_deg
    )
}

impl Section for CameraPanel {
    fn title(&self) -> &'static str {
        "Camera"
    }

    fn default_open(&self) -> bool {
        false
    }

    fn body(&mut self, ui: &mut Ui, cx: &mut Cx) {
        let (params, fields) = (&mut *cx.params, self);
        fields.forget_stale_status((params.camera.position, params.camera.target));
        ui.label(RichText::new("drag on the image to orbit, wheel to zoom").small().weak());
        egui::Grid::new("camera grid").num_columns(2).show(ui, |ui| {
            ui.label("Field of view");
            ui.add(
                egui::Slider::new(&mut params.camera.vfov_deg, FOV_RANGE)
                    .suffix("°")
                    .fixed_decimals(1),
            );
            ui.end_row();
            let eye = point_field(ui, "Eye", &mut fields.eye, params.camera.position);
            let target = point_field(ui, "Target", &mut fields.target, params.camera.target);
            if eye || target {
                fields.status = Some(match apply(params, &fields.eye, &fields.target) {
                    Ok(()) => {
                        Status::ok(format!("camera at {}", point_text(params.camera.position)))
                    }
                    Err(e) => Status::error(e),
                });
                fields.status_camera = (params.camera.position, params.camera.target);
            }
        });
        let distance = (params.camera.position - params.camera.target).length();
        ui.label(RichText::new(format!("distance {distance:.2}")).small());
        if let Some(s) = &fields.status {
            status_line(ui, s);
        }
        ui.horizontal(|ui| {
            if ui.button("Reset camera (R)").clicked() {
                params.reset_camera();
                fields.status = None;
            }
            if ui.button("Copy as flags").on_hover_text(camera_flags(&params.camera)).clicked() {
                ui.ctx().copy_text(camera_flags(&params.camera));
                fields.status = Some(Status::ok("copied the camera flags"));
                fields.status_camera = (params.camera.position, params.camera.target);
            }
        });
    }
}

/// One `X,Y,Z` row. While not being edited it shows `current`; returns whether Enter was
/// pressed in it (the text is read by [`apply`]).
fn point_field(ui: &mut Ui, name: &str, text: &mut String, current: Vec3) -> bool {
    ui.label(name);
    let id = ui.make_persistent_id(("camera field", name));
    if !ui.memory(|m| m.has_focus(id)) {
        *text = point_text(current);
    }
    let response = ui
        .add(egui::TextEdit::singleline(text).id(id).desired_width(150.0))
        .on_hover_text("X,Y,Z, applied on Enter");
    ui.end_row();
    response.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter))
}

/// Put the camera at the typed eye and target, kept inside the scene's bounds.
fn apply(params: &mut Params, eye: &str, target: &str) -> Result<(), String> {
    let eye = parse_point(eye).map_err(|e| format!("Eye: {e}"))?;
    let target = parse_point(target).map_err(|e| format!("Target: {e}"))?;
    if (eye - target).length() < 1e-3 {
        return Err("the eye and the target are the same point".into());
    }
    params.camera.position = eye;
    params.camera.target = target;
    params.keep_camera_in_view();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_error_line_goes_once_the_camera_moves() {
        // "the eye and the target are the same point" stayed red after R or a valid edit (#30).
        let here = (Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO);
        let mut panel = CameraPanel {
            status: Some(Status::error("the eye and the target are the same point")),
            status_camera: here,
            ..Default::default()
        };
        panel.forget_stale_status(here);
        assert!(panel.status.is_some(), "the camera has not moved: the line still holds");
        panel.forget_stale_status((Vec3::new(0.0, 1.0, 5.0), Vec3::ZERO));
        assert!(panel.status.is_none(), "the camera moved: the line went");
    }

    #[test]
    fn flags_read_back_as_the_same_camera() {
        let c = Camera {
            position: Vec3::new(1.0, -2.5, 3.25),
            target: Vec3::new(0.0, 0.5, 0.0),
            up: Vec3::Y,
            vfov_deg: 42.5,
        };
        let flags = camera_flags(&c);
        assert_eq!(flags, "--eye 1,-2.5,3.25 --target 0,0.5,0 --fov 42.5");
        let words: Vec<&str> = flags.split(' ').collect();
        assert_eq!(parse_point(words[1]), Ok(c.position));
        assert_eq!(parse_point(words[3]), Ok(c.target));
    }

    #[test]
    fn flags_keep_every_digit_of_an_orbited_camera() {
        // An orbit leaves coordinates like 1.2345679; two decimals moved the copied view.
        let c = Camera {
            position: Vec3::new(1.234_567_9, -0.000_123_4, 3.071_592_7),
            target: Vec3::new(0.1, 0.2, 0.3),
            up: Vec3::Y,
            vfov_deg: 42.345_68,
        };
        let flags = camera_flags(&c);
        let words: Vec<&str> = flags.split(' ').collect();
        assert_eq!(parse_point(words[1]), Ok(c.position), "{flags}");
        assert_eq!(parse_point(words[3]), Ok(c.target), "{flags}");
        assert_eq!(words[5].parse::<f32>(), Ok(c.vfov_deg), "{flags}");
    }
}
