//! The renderer headless on whatever EGL device the machine has: the GPU's driver, or Mesa's llvmpipe
//! on a machine without one (CI), with a CPU backend feeding the particles by host copy. The surface
//! mode must show water, follow viewport changes (the window's resizes and its panel), draw only
//! inside its viewport, and time its passes; the colour bar must carry its numbers. Reported as
//! ignored, with the reason, where no EGL device gives OpenGL (tests/harness: `harness = false`).

use mpm::backend::{self, BackendKind};
use mpm::render::capture::Image;
use mpm::render::headless::HeadlessGl;
use mpm::render::offline::RenderOptions;
use mpm::render::{
    Colouring, DrawMode, OrbitCamera, ParticleFeed, RenderSettings, Renderer, Transfer, Viewport,
};
use mpm::sim::{Scene, Simulation};

mod common;
mod harness;

fn main() -> std::process::ExitCode {
    let code = harness::run(
        "headless OpenGL",
        harness::headless_gl,
        harness::tests![
            surface_frames_show_water_and_time_their_passes,
            surface_follows_viewport_changes,
            colour_bar_carries_its_numbers,
            a_narrow_view_frames_the_tank_clear_of_the_colour_bar,
            every_live_particle_of_a_draining_scene_is_fed_for_drawing,
            each_material_is_drawn_in_its_colour,
            each_liquid_is_a_surface_of_its_own,
            a_solid_is_drawn_as_itself_and_in_no_liquid_surface,
            a_solid_behind_water_is_seen_through_it,
        ],
    );
    // Every test's context has dropped: the driver tears its display down now, not at exit.
    if let Err(why) = mpm::render::headless::release_displays() {
        eprintln!("{why:#}");
        return std::process::ExitCode::FAILURE;
    }
    code
}

/// The `w` x `h` rectangle of `image` whose bottom-left corner is at (x, y) in GL's convention.
fn crop(image: &Image, x: u32, y: u32, w: u32, h: u32) -> Image {
    let top = image.height - y - h;
    let mut rgba = Vec::with_capacity(4 * (w * h) as usize);
    for row in top..top + h {
        let start = 4 * (row * image.width + x) as usize;
        rgba.extend_from_slice(&image.rgba[start..start + 4 * w as usize]);
    }
    Image {
        width: w,
        height: h,
        rgba,
    }
}

fn mean_abs_difference(a: &Image, b: &Image) -> f64 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let sum: u64 = a
        .rgba
        .iter()
        .zip(&b.rgba)
        .map(|(&p, &q)| u64::from(p.abs_diff(q)))
        .sum();
    sum as f64 / a.rgba.len() as f64
}

fn surface_frames_show_water_and_time_their_passes() {
    let dir = tempfile::tempdir().expect("temp dir");
    let report = common::render_logged(RenderOptions {
        mode: DrawMode::Surface,
        transfer: Transfer::HostCopy,
        ..common::render_options("dam-break-coarse", BackendKind::CpuParallel, 6, dir.path())
    });
    let frame = std::fs::read(dir.path().join("frame-00006.png")).expect("frame 6 written");
    let image = Image::read_png(&frame).expect("PNG");
    let water = common::water_fraction(&image);
    println!("water {:.1}% of the frame, {:?}", 100.0 * water, image.stats());
    assert!(
        water > 0.02,
        "no water to be seen: {:.2}% blue pixels",
        100.0 * water
    );
    assert!(
        image.rgba.chunks_exact(4).all(|p| p[3] == 255),
        "the frame is not opaque"
    );
    let passes = &report.timings.gpu_passes_ms;
    common::assert_surface_passes_timed(passes);
    assert!(
        !passes.contains_key("particles"),
        "the surface draws no particle pass"
    );
    let total = report.timings.gpu_render_ms;
    assert!((total - passes.values().sum::<f64>()).abs() < 1e-9);
}

/// A renderer drawing one simulation state into viewports of changing size and place, as the window
/// does when it is resized or the panel changes width.
fn surface_follows_viewport_changes() {
    let headless = HeadlessGl::new(320, 180).expect("headless OpenGL");
    println!("OpenGL: {}", headless.description);
    let gl = headless.gl().clone();
    let scene = Scene::load("dam-break-coarse").expect("preset");
    let solver = backend::create(BackendKind::Cpu, &scene).expect("CPU solver");
    let (lo, hi) = scene.fluid_region();
    let domain = (lo.as_vec3(), hi.as_vec3());
    let settings =
        RenderSettings::for_scene(&scene, DrawMode::Surface, Colouring::Solid, None).expect("settings");
    let mut sim = Simulation::new(scene, solver);
    let mut renderer = Renderer::new(gl.clone()).expect("renderer");
    let mut feed = ParticleFeed::new(Transfer::HostCopy);
    let count = feed
        .update(&mut sim, &mut renderer, settings.colouring)
        .expect("particles")
        .slots;
    let camera = settings.framing(domain.0, domain.1, Viewport::full([320, 180]));
    let mut draw = |viewport: Viewport| {
        use glow::HasContext;
        // Magenta outside the viewport shows whether anything was drawn there.
        unsafe {
            gl.disable(glow::SCISSOR_TEST);
            gl.viewport(0, 0, 320, 180);
            gl.clear_color(1.0, 0.0, 1.0, 1.0);
            gl.clear(glow::COLOR_BUFFER_BIT | glow::DEPTH_BUFFER_BIT);
        }
        renderer
            .draw(viewport, &camera, &settings, count, domain)
            .expect("draw");
        headless.read_image()
    };
    let small = Viewport {
        x: 0,
        y: 0,
        width: 160,
        height: 90,
    };
    let first = crop(&draw(small), 0, 0, 160, 90);
    let full = draw(Viewport::full([320, 180]));
    let again = crop(&draw(small), 0, 0, 160, 90);
    // Beside a panel 100 pixels wide, as in the window.
    let beside = draw(Viewport {
        x: 100,
        y: 0,
        width: 220,
        height: 180,
    });
    renderer.destroy();

    let (w_first, w_full) = (common::water_fraction(&first), common::water_fraction(&full));
    println!(
        "water: {:.1}% at 160x90, {:.1}% at 320x180",
        100.0 * w_first,
        100.0 * w_full
    );
    assert!(w_first > 0.02 && w_full > 0.02, "no water drawn");
    // The same view at two resolutions covers the same share of the frame.
    assert!(
        (w_first - w_full).abs() < 0.25 * w_full,
        "160x90 shows {w_first}, 320x180 shows {w_full}"
    );
    let difference = mean_abs_difference(&first, &again);
    assert!(
        difference < 1.0,
        "the same state drawn at 160x90 before and after a 320x180 frame differs by {difference} per channel"
    );
    let left = crop(&beside, 0, 0, 100, 180);
    assert!(
        left.rgba.chunks_exact(4).all(|p| p[..3] == [255, 0, 255]),
        "the surface drew outside its viewport (left of x = 100)"
    );
    let right = crop(&beside, 100, 0, 220, 180);
    assert!(
        common::water_fraction(&right) > 0.02,
        "no water in the offset viewport"
    );
}

/// Light pixels left of the bar: its numbers and unit. With solid colouring there is no bar, and
/// that strip shows only the background.
fn colour_bar_carries_its_numbers() {
    let headless = HeadlessGl::new(640, 360).expect("headless OpenGL");
    let scene = Scene::load("dam-break-coarse").expect("preset");
    let (lo, hi) = scene.fluid_region();
    let domain = (lo.as_vec3(), hi.as_vec3());
    let camera = OrbitCamera::framing(domain.0, domain.1, glam::Vec2::new(640.0, 360.0), 0.0);
    let mut renderer = Renderer::new(headless.gl().clone()).expect("renderer");
    // No particles: only the box, the bar and its labels are drawn.
    renderer.upload(&[[0.0; 4]]);
    let mut text_pixels = |colouring: Colouring| {
        let settings =
            RenderSettings::for_scene(&scene, DrawMode::Points, colouring, None).expect("settings");
        renderer
            .draw(Viewport::full([640, 360]), &camera, &settings, 0, domain)
            .expect("draw");
        let image = headless.read_image();
        // The bar is 12 px wide, 24 px from the right edge; the numbers end 8 px left of it.
        let strip = crop(&image, 640 - 24 - 70, 0, 70, 360);
        strip
            .rgba
            .chunks_exact(4)
            .filter(|p| p[0] > 150 && p[1] > 150 && p[2] > 150)
            .count()
    };
    let speed = text_pixels(Colouring::Speed);
    let density = text_pixels(Colouring::Density);
    let solid = text_pixels(Colouring::Solid);
    renderer.destroy();
    println!("light pixels left of the bar: speed {speed}, density {density}, solid {solid}");
    assert!(
        speed > 30,
        "the speed scale's numbers are missing ({speed} light pixels)"
    );
    assert!(
        density > speed,
        "ρ/ρ0 and two decimals take more ink than m/s and one"
    );
    assert_eq!(solid, 0, "solid colouring has no scale, so no numbers");
}

/// A view narrower than tall (the scene's part of a small window beside the panel) frames the whole
/// tank by its width, and the colour bar and its numbers keep to a strip at the right edge that the
/// camera leaves free.
fn a_narrow_view_frames_the_tank_clear_of_the_colour_bar() {
    let size = [320, 450];
    let headless = HeadlessGl::new(size[0], size[1]).expect("headless OpenGL");
    let scene = Scene::load("dam-break-coarse").expect("preset");
    let solver = backend::create(BackendKind::Cpu, &scene).expect("CPU solver");
    let (lo, hi) = scene.fluid_region();
    let domain = (lo.as_vec3(), hi.as_vec3());
    let viewport = Viewport::full(size);
    let look = |colouring| RenderSettings::for_scene(&scene, DrawMode::Points, colouring, None);
    let (with_bar, without_bar) = (
        look(Colouring::Speed).expect("settings"),
        look(Colouring::Solid).expect("settings"),
    );
    let camera = with_bar.framing(domain.0, domain.1, viewport);
    let mut sim = Simulation::new(scene.clone(), solver);
    let mut renderer = Renderer::new(headless.gl().clone()).expect("renderer");
    let mut feed = ParticleFeed::new(Transfer::HostCopy);
    let count = feed
        .update(&mut sim, &mut renderer, without_bar.colouring)
        .expect("particles")
        .slots;
    let mut image = |settings: &RenderSettings, count: usize| {
        renderer
            .draw(viewport, &camera, settings, count, domain)
            .expect("draw");
        headless.read_image()
    };
    let tank = image(&without_bar, count);
    let box_alone = image(&without_bar, 0);
    let box_and_bar = image(&with_bar, 0);
    renderer.destroy();

    let strip = mpm::render::legend::clearance(viewport).ceil() as u32;
    let background = mpm::render::renderer::BACKGROUND.map(|c| (c * 255.0).round() as i32);
    let drawn = |image: &Image, x: u32, w: u32| {
        crop(image, x, 0, w, size[1])
            .rgba
            .chunks_exact(4)
            .filter(|p| (0..3).any(|c| (i32::from(p[c]) - background[c]).abs() > 2))
            .count()
    };
    let (left_edge, in_strip) = (drawn(&tank, 0, 2), drawn(&tank, size[0] - strip, strip));
    let inside = drawn(&tank, 0, size[0]);
    println!("narrow view: {inside} pixels drawn, {left_edge} at the left edge, {in_strip} in the {strip} px strip");
    assert!(inside > 2000, "the tank is missing ({inside} pixels drawn)");
    assert_eq!(left_edge, 0, "the tank is cut off at the left edge");
    assert_eq!(in_strip, 0, "the tank reaches into the colour bar's strip");
    let bar = drawn(&box_and_bar, size[0] - strip, strip);
    assert!(bar > 100, "the colour bar is missing ({bar} pixels)");
    let left = size[0] - strip;
    assert!(
        crop(&box_and_bar, 0, 0, left, size[1]).rgba == crop(&box_alone, 0, 0, left, size[1]).rgba,
        "the colour bar or its numbers reach left of its {strip} px strip"
    );
}

/// The fountain's drain parks particles of the basin's first slots from the first substep on, while
/// the basin's last slots stay live: the renderer must draw every slot, not the first `live` ones.
fn every_live_particle_of_a_draining_scene_is_fed_for_drawing() {
    let headless = HeadlessGl::new(64, 64).expect("headless OpenGL");
    let scene = Scene::load("fountain").expect("preset");
    let slots = scene.slots();
    let solver = backend::create(BackendKind::Cpu, &scene).expect("CPU solver");
    let mut sim = Simulation::new(scene, solver);
    sim.step_frame().expect("a frame");
    let mut renderer = Renderer::new(headless.gl().clone()).expect("renderer");
    let mut feed = ParticleFeed::new(Transfer::HostCopy);
    let fed = feed
        .update(&mut sim, &mut renderer, Colouring::Speed)
        .expect("particles");
    assert_eq!(fed.slots, slots, "every slot is fed");
    let buffer = renderer.read_particle_buffer(fed.slots);
    let live: Vec<usize> = (0..buffer.len()).filter(|&i| !buffer[i][0].is_nan()).collect();
    assert_eq!(
        live.len(),
        fed.live,
        "the buffer's live slots are the count the panel shows"
    );
    let highest = *live.last().expect("live particles");
    println!(
        "{} live of {} slots; the highest live slot is {highest}",
        fed.live, fed.slots
    );
    assert!(
        highest >= fed.live,
        "the drain parked no slot below a live one: the scene no longer tests what it should"
    );
    assert!(highest < fed.slots, "a live slot lies beyond what is drawn");
}

/// Two liquids side by side, red on the left (low x) and blue on the right: colouring by material
/// draws each block's particles in its material's colour, as points (the colour itself) and as the
/// surface (tinted by it); no scale bar is drawn.
fn each_material_is_drawn_in_its_colour() {
    let size = [320, 180];
    let headless = HeadlessGl::new(size[0], size[1]).expect("headless OpenGL");
    let scene = water_and_paint(
        [0.4, 0.2, 0.2],
        "",
        "[[block]]\nmin = [0.03, 0.03, 0.03]\nmax = [0.17, 0.15, 0.17]\nmaterial = \"paint\"\n\
         [[block]]\nmin = [0.23, 0.03, 0.03]\nmax = [0.37, 0.15, 0.17]\nmaterial = \"water\"\n",
    );
    assert_eq!(Colouring::default_for(&scene), Colouring::Material);
    let settings =
        RenderSettings::for_scene(&scene, DrawMode::Points, Colouring::Material, None).expect("settings");
    assert_eq!(settings.legend(), None);
    let points = drawn_by_material(&headless, &scene, DrawMode::Points, size);
    let surface = drawn_by_material(&headless, &scene, DrawMode::Surface, size);
    let tally = |image: &Image, x: u32| red_and_blue(image, (x, 0, size[0] / 2, size[1]));
    for (what, image) in [("points", &points), ("surface", &surface)] {
        let (left, right) = (tally(image, 0), tally(image, size[0] / 2));
        println!("{what}: left (red, blue) {left:?}, right {right:?}");
        assert!(
            left.0 > 800,
            "{what}: the red liquid is missing on the left: {left:?}"
        );
        assert!(
            right.1 > 800,
            "{what}: the blue liquid is missing on the right: {right:?}"
        );
        assert!(
            left.0 > 5 * left.1,
            "{what}: the left is not mostly red: {left:?}"
        );
        assert!(
            right.0 * 5 < right.1,
            "{what}: the right is not mostly blue: {right:?}"
        );
    }
    // The points are drawn in the material's colour itself.
    let exact = points
        .rgba
        .chunks_exact(4)
        .filter(|p| p[0].abs_diff(230) <= 1 && p[1].abs_diff(26) <= 1 && p[2].abs_diff(26) <= 1)
        .count();
    assert!(exact > 200, "{exact} pixels of paint's colour (230, 26, 26)");
}

/// Two liquids one behind the other: blue water across the back of the tank, red paint in front of
/// its left half. Each liquid is a surface of its own, laid over the scene far to near with its own
/// absorption: opaque paint (`absorption = 30`) hides the water behind it and shows red; clear paint
/// (`absorption = 0`) tints nothing, and the water behind it shows through.
fn each_liquid_is_a_surface_of_its_own() {
    let size = [320, 180];
    let headless = HeadlessGl::new(size[0], size[1]).expect("headless OpenGL");
    let image_with = |front_absorption: f32| {
        let scene = water_and_paint(
            [0.4, 0.2, 0.4],
            &format!("absorption = {front_absorption}\n"),
            "[[block]]\nmin = [0.03, 0.03, 0.03]\nmax = [0.37, 0.15, 0.15]\nmaterial = \"water\"\n\
             [[block]]\nmin = [0.03, 0.03, 0.25]\nmax = [0.19, 0.15, 0.37]\nmaterial = \"paint\"\n",
        );
        drawn_by_material(&headless, &scene, DrawMode::Surface, size)
    };
    let left = (0, 0, size[0] / 2, size[1]);
    let right = (size[0] / 2, 0, size[0] / 2, size[1]);
    // The paint's front face in the default framing (the left block's middle, 30 x 20 pixels).
    let paint = (105, 70, 30, 20);
    let opaque = image_with(30.0);
    let clear = image_with(0.0);
    for (what, image) in [("opaque", &opaque), ("clear", &clear)] {
        println!(
            "{what} paint in front: (red, blue) left {:?}, right {:?}, the paint's face {:?}",
            red_and_blue(image, left),
            red_and_blue(image, right),
            red_and_blue(image, paint)
        );
    }
    let face = red_and_blue(&opaque, paint);
    assert!(
        face.0 >= 570,
        "the opaque paint's face is not red (of 600 pixels): {face:?}"
    );
    let (r, b) = red_and_blue(&opaque, right);
    assert!(
        b > 800 && b > 5 * r,
        "the water on the right is not blue: {:?}",
        (r, b)
    );
    let see_through = red_and_blue(&clear, paint);
    assert!(
        see_through.0 <= 30,
        "a clear liquid tints what is behind it: {see_through:?} (red, blue) on the paint's face"
    );
    // Much of what lies behind the paint's face is floor, not water: on an H100 the clear paint
    // showed 343 more blue pixels in the left half than the opaque.
    let (opaque_left, clear_left) = (red_and_blue(&opaque, left), red_and_blue(&clear, left));
    assert!(
        clear_left.1 > opaque_left.1 + 150,
        "the water does not show through a clear liquid in front of it: blue pixels {} behind clear paint, {} behind opaque",
        clear_left.1,
        opaque_left.1
    );
}

/// A green jelly cube (fixed-corotated) on the floor at the left of a small tank, a pool of blue water
/// at the right, three frames on: the surface draws the jelly as lit spheres of its own colour, in
/// the scene behind the water, and leaves it out of the water's surface. Against the same tank without
/// the jelly: the jelly's part of the frame is its colour and shows no more water, the water's
/// thickness there stays nil, and its colour is nowhere else; whether the surface is coloured by
/// material (one surface per liquid: here one) or by speed (the one surface of every particle).
fn a_solid_is_drawn_as_itself_and_in_no_liquid_surface() {
    let size = [320, 180];
    let viewport = Viewport::full(size);
    let headless = HeadlessGl::new(size[0], size[1]).expect("headless OpenGL");
    let jelly = "[[block]]\nmin = [0.02, 0.01, 0.06]\nmax = [0.12, 0.11, 0.16]\nmaterial = \"jelly\"\n";
    let (with_jelly, water_alone) = (water_and_jelly(jelly), water_and_jelly(""));
    let green = |p: &[u8]| i32::from(p[1]) > i32::from(p[0]) + 40 && i32::from(p[1]) > i32::from(p[2]) + 40;
    let blue = |p: &[u8]| i32::from(p[2]) > i32::from(p[0]) + 30 && i32::from(p[2]) > i32::from(p[1]) + 10;
    let count = |image: &Image, rect: Rect, keep: &dyn Fn(&[u8]) -> bool| {
        let part = crop(image, rect.0, rect.1, rect.2, rect.3);
        part.rgba.chunks_exact(4).filter(|p| keep(p)).count()
    };
    for colouring in [Colouring::Material, Colouring::Speed] {
        let drawn = drawn_after_frames(&headless, &with_jelly, colouring, size, 3);
        let alone = drawn_after_frames(&headless, &water_alone, colouring, size, 3);
        let (rows, water_rows) = (drawn.rows.len(), alone.rows.len());
        assert!(
            rows == drawn.particles.len() && water_rows == alone.particles.len(),
            "a scene with a solid feeds every slot's material row ({rows} rows, {water_rows} without the jelly)"
        );
        // Where the jelly's particles are on screen, and the water's; the jelly's box grown by its
        // spheres' radius and a margin (the legend's strip kept out for the speed's colour bar).
        let jelly_box = drawn.screen_box(|row| row == 1).expect("jelly on screen");
        let water_box = drawn.screen_box(|row| row == 0).expect("water on screen");
        let around_jelly = grow(jelly_box, 8, size);
        assert!(
            !overlap(around_jelly, water_box),
            "the water has reached the jelly on screen: the scene no longer tests what it should \
             (jelly {jelly_box:?}, water {water_box:?})"
        );
        let inside_jelly = shrink(jelly_box, 0.2);
        let inside = inside_jelly.2 as usize * inside_jelly.3 as usize;
        let jelly_green = count(&drawn.image, inside_jelly, &green);
        let (blue_jelly, blue_alone) = (
            count(&drawn.image, around_jelly, &blue),
            count(&alone.image, around_jelly, &blue),
        );
        let strip = match colouring {
            Colouring::Speed => mpm::render::legend::clearance(viewport).ceil() as u32,
            _ => 0,
        };
        let everywhere = (0, 0, size[0] - strip, size[1]);
        let green_elsewhere =
            count(&drawn.image, everywhere, &green) - count(&drawn.image, around_jelly, &green);
        let water_thickness = thickness_in(&drawn, water_box);
        let jelly_thickness = thickness_in(&drawn, around_jelly);
        println!(
            "{colouring:?}: jelly at {jelly_box:?}, {jelly_green} of {inside} pixels inside it green, \
             {green_elsewhere} green elsewhere; blue around it {blue_jelly} (without the jelly {blue_alone}); \
             water thickness summed {water_thickness:.4} m over its part, {jelly_thickness:.6} m over the jelly's"
        );
        assert!(
            jelly_green * 10 >= inside * 9,
            "{colouring:?}: the jelly is not drawn in its colour: {jelly_green} of {inside} pixels green"
        );
        assert!(
            green_elsewhere <= 4,
            "{colouring:?}: the jelly's colour where there is no jelly: {green_elsewhere} pixels"
        );
        assert!(
            blue_jelly <= blue_alone,
            "{colouring:?}: the jelly is drawn as water: {blue_jelly} blue pixels around it, {blue_alone} without it"
        );
        assert!(water_thickness > 0.0, "{colouring:?}: the water has no thickness");
        assert_eq!(
            jelly_thickness, 0.0,
            "{colouring:?}: the jelly adds to the liquid's thickness"
        );
    }
}

/// A green jelly cube on the floor behind a wall of blue water (nearer the camera), and red paint
/// aside, as drawn at the start: the jelly is in the scene the water covers, so through the water it
/// shows tinted blue and still green, coloured by material (two liquids, a surface each, the jelly's
/// row in neither) and by speed (one surface); drawn as one surface, the water's thickness over the
/// jelly is the wall's alone.
fn a_solid_behind_water_is_seen_through_it() {
    let size = [320, 180];
    let headless = HeadlessGl::new(size[0], size[1]).expect("headless OpenGL");
    let scene = |bodies: &str| {
        jelly_tank(&format!(
            "[[material]]\nname = \"paint\"\nrest_density = 1000.0\nsound_speed = 20.0\ncolour = [0.9, 0.1, 0.1]\n\
             [[block]]\nmin = [0.28, 0.01, 0.05]\nmax = [0.36, 0.07, 0.13]\nmaterial = \"paint\"\n{bodies}"
        ))
    };
    let jelly = "[[block]]\nmin = [0.05, 0.01, 0.03]\nmax = [0.13, 0.07, 0.09]\nmaterial = \"jelly\"\n";
    let wall = "[[block]]\nmin = [0.01, 0.01, 0.11]\nmax = [0.2, 0.13, 0.18]\nmaterial = \"water\"\n";
    let behind_water = scene(&format!("{jelly}{wall}"));
    let (in_the_open, wall_alone) = (scene(jelly), scene(wall));
    for colouring in [Colouring::Material, Colouring::Speed] {
        let covered = drawn_after_frames(&headless, &behind_water, colouring, size, 0);
        let open = drawn_after_frames(&headless, &in_the_open, colouring, size, 0);
        let water = drawn_after_frames(&headless, &wall_alone, colouring, size, 0);
        let jelly = shrink(covered.screen_box(|row| row == 1).expect("jelly on screen"), 0.2);
        let pixels = crop(&covered.image, jelly.0, jelly.1, jelly.2, jelly.3);
        let bare = crop(&open.image, jelly.0, jelly.1, jelly.2, jelly.3);
        let mean = |image: &Image, channel: usize| {
            let values = image.rgba.chunks_exact(4).map(|p| f64::from(p[channel]));
            values.sum::<f64>() / f64::from(image.width * image.height)
        };
        // Green over blue: the water's own colour has more blue than green.
        let greenish = common::pixel_fraction(&pixels, |p| i32::from(p[1]) > i32::from(p[2]) + 10);
        let (blue, bare_blue) = (mean(&pixels, 2), mean(&bare, 2));
        let changed = pixels
            .rgba
            .chunks_exact(4)
            .zip(bare.rgba.chunks_exact(4))
            .filter(|(a, b)| a != b)
            .count();
        let area = (jelly.2 * jelly.3) as usize;
        let (over_jelly, wall_only) = (thickness_in(&covered, jelly), thickness_in(&water, jelly));
        println!(
            "{colouring:?}: jelly's middle {jelly:?}: {changed} of {area} pixels changed by the water in front, \
             {:.0}% still green over blue, mean blue {blue:.0} (bare {bare_blue:.0}); water thickness over it \
             {over_jelly:.4} m (the wall alone {wall_only:.4} m)",
            100.0 * greenish
        );
        assert!(
            changed * 2 > area,
            "{colouring:?}: the water in front does not cover the jelly: {changed} of {area} pixels changed"
        );
        assert!(
            blue > bare_blue + 10.0,
            "{colouring:?}: the jelly behind the water is not tinted by it: mean blue {blue:.0}, bare {bare_blue:.0}"
        );
        assert!(
            greenish > 0.3,
            "{colouring:?}: the jelly does not show through the water: {:.0}% green over blue",
            100.0 * greenish
        );
        // By material, each liquid's thickness is a layer of its own, not the texture read here.
        if colouring == Colouring::Speed {
            assert!(
                wall_only > 0.0,
                "no water over the jelly: the scene no longer tests what it should"
            );
            // The same water splatted in another order: half floats round differently.
            assert!(
                (over_jelly - wall_only).abs() <= 0.02 * wall_only,
                "the jelly adds to the water's thickness: {over_jelly} m over it, the wall alone {wall_only} m"
            );
        }
    }
}

/// A `(x, y, w, h)` rectangle of a frame, pixels from its bottom-left corner (GL's convention).
type Rect = (u32, u32, u32, u32);

fn grow((x, y, w, h): Rect, by: u32, size: [u32; 2]) -> Rect {
    let (x0, y0) = (x.saturating_sub(by), y.saturating_sub(by));
    let (x1, y1) = ((x + w + by).min(size[0]), (y + h + by).min(size[1]));
    (x0, y0, x1 - x0, y1 - y0)
}

/// The middle of `rect`, `by` of its width and height off each side.
fn shrink((x, y, w, h): Rect, by: f32) -> Rect {
    let (dx, dy) = ((w as f32 * by) as u32, (h as f32 * by) as u32);
    (x + dx, y + dy, w - 2 * dx, h - 2 * dy)
}

fn overlap(a: Rect, b: Rect) -> bool {
    a.0 < b.0 + b.2 && b.0 < a.0 + a.2 && a.1 < b.1 + b.3 && b.1 < a.1 + a.3
}

/// The liquid's thickness summed over the thickness texels that cover `rect`, m.
fn thickness_in(drawn: &Drawn, (x, y, w, h): Rect) -> f32 {
    let ([tw, th], texels) = &drawn.thickness;
    let scale = |v: u32, full: u32, texels: u32| (v * texels / full).min(texels);
    let [fw, fh] = [drawn.image.width, drawn.image.height];
    let (x0, x1) = (
        scale(x, fw, *tw),
        scale(x + w, fw, *tw).max(scale(x, fw, *tw) + 1),
    );
    let (y0, y1) = (
        scale(y, fh, *th),
        scale(y + h, fh, *th).max(scale(y, fh, *th) + 1),
    );
    let mut sum = 0.0;
    for ty in y0..y1.min(*th) {
        for tx in x0..x1.min(*tw) {
            sum += texels[(ty * tw + tx) as usize][0];
        }
    }
    sum
}

/// A frame drawn by [`drawn_after_frames`], with what the renderer was given and made.
struct Drawn {
    image: Image,
    /// The surface's thickness texture ([`Renderer::read_thickness`]).
    thickness: ([u32; 2], Vec<[f32; 2]>),
    /// The particle buffer: position and colour quantity per slot.
    particles: Vec<[f32; 4]>,
    /// The buffer's material rows section: each slot's row in w.
    rows: Vec<[f32; 4]>,
    view_proj: glam::Mat4,
}

impl Drawn {
    /// The pixels that the centres of the particles whose row `pick` picks project into.
    fn screen_box(&self, pick: impl Fn(u32) -> bool) -> Option<Rect> {
        let [w, h] = [self.image.width as f32, self.image.height as f32];
        let (mut lo, mut hi) = (
            glam::Vec2::splat(f32::INFINITY),
            glam::Vec2::splat(f32::NEG_INFINITY),
        );
        for (p, row) in self.particles.iter().zip(&self.rows) {
            if p[0].is_nan() || !pick(row[3] as u32) {
                continue;
            }
            let ndc = self.view_proj.project_point3(glam::Vec3::new(p[0], p[1], p[2]));
            let pixel = glam::Vec2::new((ndc.x + 1.0) * 0.5 * w, (ndc.y + 1.0) * 0.5 * h);
            (lo, hi) = (lo.min(pixel), hi.max(pixel));
        }
        (lo.x <= hi.x).then(|| {
            let (x0, y0) = (lo.x.max(0.0) as u32, lo.y.max(0.0) as u32);
            let (x1, y1) = (hi.x.min(w).ceil() as u32, hi.y.min(h).ceil() as u32);
            (x0, y0, x1 - x0, y1 - y0)
        })
    }
}

/// `scene` after `frames` frames on the CPU backend, drawn as its surface coloured by `colouring` at
/// `size`, framed as the viewer frames it.
fn drawn_after_frames(
    headless: &HeadlessGl,
    scene: &Scene,
    colouring: Colouring,
    size: [u32; 2],
    frames: usize,
) -> Drawn {
    let solver = backend::create(BackendKind::Cpu, scene).expect("CPU solver");
    let (lo, hi) = scene.fluid_region();
    let domain = (lo.as_vec3(), hi.as_vec3());
    let viewport = Viewport::full(size);
    let mut sim = Simulation::new(scene.clone(), solver);
    for _ in 0..frames {
        sim.step_frame().expect("a frame");
    }
    let mut renderer = Renderer::new(headless.gl().clone()).expect("renderer");
    let mut feed = ParticleFeed::new(Transfer::HostCopy);
    let count = feed
        .update(&mut sim, &mut renderer, colouring)
        .expect("particles")
        .slots;
    let settings = RenderSettings::for_scene(scene, DrawMode::Surface, colouring, None).expect("settings");
    let camera = settings.framing(domain.0, domain.1, viewport);
    renderer
        .draw(viewport, &camera, &settings, count, domain)
        .expect("draw");
    let drawn = Drawn {
        image: headless.read_image(),
        thickness: renderer.read_thickness().expect("a surface frame"),
        particles: renderer.read_particle_buffer(count),
        rows: renderer.read_material_rows(count),
        view_proj: camera.projection(size[0] as f32 / size[1] as f32) * camera.view(),
    };
    renderer.destroy();
    drawn
}

/// A tank 0.4 x 0.2 x 0.2 m at dx = 1 cm holding a shallow pool of blue water at its right and
/// `bodies`, with a material "jelly": a firm green solid (fixed-corotated, E = 40 kPa, nu = 0.3).
fn water_and_jelly(bodies: &str) -> Scene {
    jelly_tank(&format!(
        "[[block]]\nmin = [0.26, 0.01, 0.01]\nmax = [0.38, 0.07, 0.18]\nmaterial = \"water\"\n{bodies}"
    ))
}

/// A tank 0.4 x 0.2 x 0.2 m at dx = 1 cm with the materials "water" (blue) and "jelly" (a firm green
/// solid: fixed-corotated, E = 40 kPa, nu = 0.3), rows 0 and 1, and `rest` after them (more
/// materials, then the bodies).
fn jelly_tank(rest: &str) -> Scene {
    Scene::from_toml(
        &format!(
            "[domain]\nsize = [0.4, 0.2, 0.2]\nresolution = [40, 20, 20]\n\
             [[material]]\nname = \"water\"\nrest_density = 1000.0\nsound_speed = 20.0\ncolour = [0.1, 0.2, 0.9]\n\
             [[material]]\nname = \"jelly\"\nlaw = \"fixed-corotated\"\nrest_density = 1000.0\n\
             youngs_modulus = 4.0e4\npoisson_ratio = 0.3\ncolour = [0.15, 0.8, 0.2]\n{rest}"
        ),
        "jelly-tank.toml",
    )
    .expect("scene")
}

/// A tank of `size` m at dx = 1 cm with two liquids of water's density, "water" (blue) and "paint"
/// (red, with `paint_keys` added to its entry), and `bodies`.
fn water_and_paint(size: [f32; 3], paint_keys: &str, bodies: &str) -> Scene {
    let [x, y, z] = size;
    let res = size.map(|s| (s / 0.01).round() as u32);
    Scene::from_toml(
        &format!(
            "[domain]\nsize = [{x}, {y}, {z}]\nresolution = [{}, {}, {}]\n\
             [[material]]\nname = \"water\"\nrest_density = 1000.0\nsound_speed = 20.0\ncolour = [0.1, 0.2, 0.9]\n\
             [[material]]\nname = \"paint\"\nrest_density = 1000.0\nsound_speed = 20.0\ncolour = [0.9, 0.1, 0.1]\n\
             {paint_keys}{bodies}",
            res[0], res[1], res[2]
        ),
        "water-and-paint.toml",
    )
    .expect("scene")
}

/// `scene`'s first state on the CPU backend, coloured by material and drawn in `mode` at `size`,
/// framed as the viewer frames it.
fn drawn_by_material(headless: &HeadlessGl, scene: &Scene, mode: DrawMode, size: [u32; 2]) -> Image {
    let solver = backend::create(BackendKind::Cpu, scene).expect("CPU solver");
    let (lo, hi) = scene.fluid_region();
    let domain = (lo.as_vec3(), hi.as_vec3());
    let viewport = Viewport::full(size);
    let mut sim = Simulation::new(scene.clone(), solver);
    let mut renderer = Renderer::new(headless.gl().clone()).expect("renderer");
    let mut feed = ParticleFeed::new(Transfer::HostCopy);
    let count = feed
        .update(&mut sim, &mut renderer, Colouring::Material)
        .expect("particles")
        .slots;
    let settings = RenderSettings::for_scene(scene, mode, Colouring::Material, None).expect("settings");
    let camera = settings.framing(domain.0, domain.1, viewport);
    renderer
        .draw(viewport, &camera, &settings, count, domain)
        .expect("draw");
    let image = headless.read_image();
    renderer.destroy();
    image
}

/// Pixels that are mostly red, and mostly blue, in the `w` x `h` rectangle of `image` at (x, y).
fn red_and_blue(image: &Image, (x, y, w, h): (u32, u32, u32, u32)) -> (usize, usize) {
    let part = crop(image, x, y, w, h);
    let (mut red, mut blue) = (0, 0);
    for p in part.rgba.chunks_exact(4) {
        let (r, b) = (i32::from(p[0]), i32::from(p[2]));
        if r > b + 30 {
            red += 1;
        } else if b > r + 30 {
            blue += 1;
        }
    }
    (red, blue)
}
