//! An orbit camera: it turns around a target point (left drag), slides the target in the view plane
//! (right drag) and moves nearer or farther (wheel). It frames a box on start and on reset.

use glam::{Mat4, Vec2, Vec3, Vec4};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrbitCamera {
    pub target: Vec3,
    /// Eye distance from the target, m.
    pub distance: f32,
    /// Rotation about +y, radians.
    pub yaw: f32,
    /// Elevation above the xz plane, radians, within +-89 degrees.
    pub pitch: f32,
    /// Vertical field of view, radians.
    pub fov_y: f32,
}

const PITCH_LIMIT: f32 = 89.0 * std::f32::consts::PI / 180.0;

impl OrbitCamera {
    /// Looks at the box [lo, hi] from the front, a little above and to the side, from a distance at
    /// which its bounding sphere fits a viewport of `size` pixels both ways, centred in what is left
    /// of it after a strip `clear_right` pixels wide at the right edge (where the colour bar goes).
    pub fn framing(lo: Vec3, hi: Vec3, size: Vec2, clear_right: f32) -> OrbitCamera {
        let fov_y = 40f32.to_radians();
        let radius = 0.5 * (hi - lo).length();
        let free = Vec2::new((size.x - clear_right).max(1.0), size.y.max(1.0));
        // A window narrower than the box (a small one beside the panel) is fitted by its width.
        let half_x = (free.x / free.y * (0.5 * fov_y).tan()).atan();
        let half = half_x.min(0.5 * fov_y);
        let mut camera = OrbitCamera {
            target: 0.5 * (lo + hi),
            distance: 1.1 * radius / half.sin(),
            yaw: 25f32.to_radians(),
            pitch: 20f32.to_radians(),
            fov_y,
        };
        camera.pan(Vec2::new(-0.5 * clear_right, 0.0), size.y);
        camera
    }

    pub fn eye(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        self.target + self.distance * Vec3::new(cp * sy, sp, cp * cy)
    }

    pub fn view(&self) -> Mat4 {
        look_at(self.eye(), self.target, Vec3::Y)
    }

    /// Perspective with near/far planes scaled to the distance, so depth precision follows the zoom.
    pub fn projection(&self, aspect: f32) -> Mat4 {
        perspective(
            self.fov_y,
            aspect.max(1e-3),
            0.01 * self.distance,
            10.0 * self.distance,
        )
    }

    /// Turns by a drag of `delta` pixels.
    pub fn orbit(&mut self, delta: Vec2) {
        self.yaw -= delta.x * 0.005;
        self.pitch = (self.pitch + delta.y * 0.005).clamp(-PITCH_LIMIT, PITCH_LIMIT);
    }

    /// Slides the target so the scene follows a drag of `delta` pixels in a viewport `height` high.
    pub fn pan(&mut self, delta: Vec2, height: f32) {
        let metres_per_pixel = 2.0 * self.distance * (0.5 * self.fov_y).tan() / height.max(1.0);
        let view = self.view();
        let right = view.row(0).truncate();
        let up = view.row(1).truncate();
        self.target += (-delta.x * right + delta.y * up) * metres_per_pixel;
    }

    /// Moves nearer (positive `steps`) or farther by 10% per wheel step.
    pub fn zoom(&mut self, steps: f32) {
        self.distance = (self.distance * 0.9f32.powf(steps)).clamp(1e-3, 1e4);
    }

    /// The world-space ray through pixel `cursor` (origin top left) of a `size` viewport:
    /// (origin, unit direction).
    pub fn ray(&self, cursor: Vec2, size: Vec2) -> (Vec3, Vec3) {
        let ndc = Vec2::new(
            2.0 * cursor.x / size.x.max(1.0) - 1.0,
            1.0 - 2.0 * cursor.y / size.y.max(1.0),
        );
        let inverse = (self.projection(size.x / size.y.max(1.0)) * self.view()).inverse();
        let near = inverse.project_point3(ndc.extend(-1.0));
        let far = inverse.project_point3(ndc.extend(1.0));
        (self.eye(), (far - near).normalize_or_zero())
    }

    /// World-space metres that one pixel spans at the target's depth.
    pub fn metres_per_pixel(&self, height: f32) -> f32 {
        2.0 * self.distance * (0.5 * self.fov_y).tan() / height.max(1.0)
    }
}

/// Right-handed view matrix (camera looks down -z), as gluLookAt.
fn look_at(eye: Vec3, target: Vec3, up: Vec3) -> Mat4 {
    let f = (target - eye).normalize();
    let s = f.cross(up).normalize();
    let u = s.cross(f);
    Mat4::from_cols(
        Vec4::new(s.x, u.x, -f.x, 0.0),
        Vec4::new(s.y, u.y, -f.y, 0.0),
        Vec4::new(s.z, u.z, -f.z, 0.0),
        Vec4::new(-s.dot(eye), -u.dot(eye), f.dot(eye), 1.0),
    )
}

/// OpenGL perspective projection (depth to [-1, 1] clip space), as gluPerspective.
fn perspective(fov_y: f32, aspect: f32, near: f32, far: f32) -> Mat4 {
    let f = 1.0 / (0.5 * fov_y).tan();
    Mat4::from_cols(
        Vec4::new(f / aspect, 0.0, 0.0, 0.0),
        Vec4::new(0.0, f, 0.0, 0.0),
        Vec4::new(0.0, 0.0, (far + near) / (near - far), -1.0),
        Vec4::new(0.0, 0.0, 2.0 * far * near / (near - far), 0.0),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn framing_sees_the_whole_box_left_of_the_strip() {
        // A wide window, a small one beside the panel (narrower than tall), and a tall one.
        for (size, clear) in [
            ((1600.0, 900.0), 0.0),
            ((500.0, 450.0), 60.0),
            ((400.0, 900.0), 40.0),
        ] {
            let size = Vec2::new(size.0, size.1);
            let camera = OrbitCamera::framing(Vec3::ZERO, Vec3::new(1.0, 0.5, 0.5), size, clear);
            let clip = camera.projection(size.x / size.y) * camera.view();
            let right_edge = 1.0 - 2.0 * clear / size.x;
            let mut xs = (f32::MAX, f32::MIN);
            for corner in 0..8 {
                let p = Vec3::new(
                    (corner & 1) as f32,
                    0.5 * ((corner >> 1) & 1) as f32,
                    0.5 * ((corner >> 2) & 1) as f32,
                );
                let ndc = clip.project_point3(p);
                assert!(
                    ndc.x >= -1.0 && ndc.x <= right_edge && ndc.y.abs() <= 1.0,
                    "{size} with {clear} px kept clear: corner {p} falls outside: {ndc}"
                );
                xs = (xs.0.min(ndc.x), xs.1.max(ndc.x));
            }
            // Centred in the free part, not pushed against one side.
            let centre = 0.5 * (xs.0 + xs.1);
            let free_centre = 0.5 * (right_edge - 1.0);
            assert!(
                (centre - free_centre).abs() < 0.1,
                "{size}: box centred at {centre}, free part at {free_centre}"
            );
        }
    }

    #[test]
    fn ray_through_the_centre_hits_the_target() {
        let camera = OrbitCamera::framing(Vec3::ZERO, Vec3::ONE, Vec2::new(800.0, 600.0), 0.0);
        let (origin, direction) = camera.ray(Vec2::new(400.0, 300.0), Vec2::new(800.0, 600.0));
        let to_target = (camera.target - origin).normalize();
        assert!(direction.dot(to_target) > 0.9999);
    }
}
