//! The viewer's GPU paths on an NVIDIA machine, headless: CUDA-OpenGL interop through an EGL device
//! context, the push kernel against the CPU formula, and a headless render against a stored frame.
//! Where there is no CUDA device or no EGL device with OpenGL, every test is reported as ignored, with
//! the reason (tests/harness: `harness = false`).

use glam::Vec3;
use mpm::backend::BackendKind;
use mpm::cuda::interop::GlBufferResource;
use mpm::cuda::render::DeviceParticlesView;
use mpm::cuda::{CudaOptions, CudaSolver};
use mpm::render::capture::{Image, ImageStats};
use mpm::render::headless::HeadlessGl;
use mpm::render::offline::RenderOptions;
use mpm::render::ColourBy;
use mpm::render::{
    Colouring, DrawMode, OrbitCamera, ParticleFeed, RenderSettings, Renderer, Transfer, Viewport,
};
use mpm::sim::cpu::CpuSolver;
use mpm::sim::{ParticleView, Push, Scene, Simulation, Solver};

mod common;
mod harness;

fn main() -> std::process::ExitCode {
    harness::run(
        "GPU",
        harness::cuda_device_and_headless_gl,
        harness::tests![
            interop_round_trip_through_gl,
            push_agrees_between_cpu_and_cuda,
            headless_render_matches_reference,
            surface_render_matches_reference,
            surface_render_through_host_copy_matches_reference,
            thickness_summed_by_cuda_is_the_thickness_gl_blends,
            solid_rows_arrive_through_interop_and_host_copy,
        ],
    )
}

fn interop_round_trip_through_gl() {
    let headless = HeadlessGl::new(64, 64).expect("headless OpenGL");
    println!("OpenGL: {}", headless.description);
    let scene = Scene::load("drop").expect("preset");
    let n = scene.num_particles;
    let rest_density = scene.material().rest_density;
    let solver = CudaSolver::new(&scene, CudaOptions::default()).expect("CUDA solver");
    let mut sim = Simulation::new(scene, Box::new(solver));
    // A few frames, so speeds differ from particle to particle.
    for _ in 0..5 {
        sim.step_frame().expect("step");
    }
    let expected = sim.solver_mut().read_particles().expect("read back");
    let ParticleView::Device(view) = sim.solver().particles() else {
        panic!("a CUDA solver keeps its particles on the device");
    };
    let cuda = DeviceParticlesView::of(view.as_ref()).expect("a CUDA solver's own view");

    let mut renderer = Renderer::new(headless.gl().clone()).expect("renderer");
    renderer.ensure_capacity(n);
    let quantities = [ColourBy::Speed, ColourBy::Density, ColourBy::Material];
    for (round, colour_by) in quantities.into_iter().enumerate() {
        // Register, map, write with the kernel, unmap; once for each quantity, so release and
        // re-registration work.
        let mut registration =
            unsafe { GlBufferResource::register(cuda.context(), renderer.particle_buffer_name()) }
                .expect("cuGraphicsGLRegisterBuffer");
        let stream = cuda.stream().clone();
        let mapped = registration.map(&stream).expect("map");
        assert!(
            mapped.bytes >= 16 * n,
            "mapped {} bytes for {n} particles",
            mapped.bytes
        );
        unsafe { cuda.write_render_attributes(colour_by, rest_density, mapped.ptr) }.expect("kernel");
        registration.unmap(&stream).expect("unmap");
        let seen = renderer.read_particle_buffer(n);
        drop(registration);

        let mut worst = 0f32;
        for (i, v) in seen.iter().enumerate() {
            assert_eq!(
                [v[0], v[1], v[2]],
                expected.x[i].to_array(),
                "particle {i} position"
            );
            let want = colour_by.value(expected.v[i], expected.rho[i], rest_density, expected.material[i]);
            worst = worst.max((v[3] - want).abs() / want.abs().max(1e-3));
        }
        println!("round {round} ({colour_by:?}): {n} particles, worst relative error {worst:.2e}");
        assert!(worst < 1e-5, "colour quantity off by {worst}");
    }
    renderer.destroy();
}

fn push_agrees_between_cpu_and_cuda() {
    let scene = Scene::load("drop").expect("preset");
    let mut cpu = CpuSolver::new(scene.spawn(), scene.grid_res);
    let mut cuda = CudaSolver::new(&scene, CudaOptions::default()).expect("CUDA solver");
    let (lo, hi) = scene.fluid_region();
    let centre = (0.5 * (lo + hi)).as_vec3();
    let push = Push::new(
        centre - Vec3::new(0.0, 0.0, 2.0),
        Vec3::Z,
        0.3 * (hi - lo).as_vec3().max_element(),
        Vec3::new(1.5, -0.5, 0.25),
    );
    cpu.apply_push(&push).expect("cpu push");
    cuda.apply_push(&push).expect("cuda push");
    let (a, b) = (
        cpu.read_particles().expect("cpu"),
        cuda.read_particles().expect("cuda"),
    );
    let pushed = a.v.iter().filter(|v| v.length() > 0.0).count();
    assert!(pushed > 0, "the push missed every particle");
    for i in 0..a.len() {
        assert!(
            (a.v[i] - b.v[i]).length() < 1e-5,
            "particle {i}: cpu {} cuda {}",
            a.v[i],
            b.v[i]
        );
    }
    println!(
        "push: {pushed} of {} particles pushed; CPU and CUDA agree",
        a.len()
    );
}

/// Frame 30 of `mpm render --scene dam-break --frames 30 --size 320x180 --backend cuda --draw spheres
/// --out DIR`
/// (spheres coloured by speed, interop), made on an NVIDIA H200 on 2026-11-21, before the colour bar
/// carried its numbers: at this size they cover about 0.4 % of the frame and raise the mean colour by
/// 0.3 per channel (measured on Mesa), inside the bounds below. Embedded, so the test binary runs
/// anywhere; `MPM_WRITE_REFERENCE=DIR` writes a new one as for the surface.
const REFERENCE_FRAME: &[u8] = include_bytes!("reference/dam-break-30-320x180.png");

fn headless_render_matches_reference() {
    let dir = tempfile::tempdir().expect("temp dir");
    let report = common::render_logged(common::render_options(
        "dam-break",
        BackendKind::Cuda,
        30,
        dir.path(),
    ));
    assert_eq!(
        report.path, "CUDA-GL interop",
        "the CUDA backend must draw through interop"
    );
    let path = dir.path().join("frame-00030.png");
    write_reference_if_asked(&path, "dam-break-30-320x180.png");
    let frame = std::fs::read(&path).expect("frame 30 written");
    let got = Image::read_png(&frame).expect("PNG").stats();
    let want = Image::read_png(REFERENCE_FRAME).expect("reference PNG").stats();
    assert_close_to_reference(&got, &want);
}

/// The float scatter sums in a varying order, so the splash differs in detail from run to run; the
/// statistics of the frame (how much is covered, where, in what colours) barely move. A wrong camera,
/// colour scale, depth test or an empty buffer moves them far past these bounds.
fn assert_close_to_reference(got: &ImageStats, want: &ImageStats) {
    println!("rendered  {got:?}\nreference {want:?}");
    assert!(want.covered_fraction > 0.05, "the reference shows no fluid");
    let covered = (got.covered_fraction - want.covered_fraction).abs();
    assert!(
        covered < 0.1 * want.covered_fraction + 0.005,
        "covered fraction off by {covered}"
    );
    for k in 0..2 {
        let d = (got.centroid[k] - want.centroid[k]).abs();
        assert!(d < 0.02, "centroid axis {k} off by {d}");
    }
    for k in 0..3 {
        let d = (got.mean_rgb[k] - want.mean_rgb[k]).abs();
        assert!(d < 3.0, "mean channel {k} off by {d}");
    }
}

/// The surface's reference frame: frame 30 of `mpm render --scene dam-break --frames 30 --size
/// 480x270 --backend cuda --draw surface --colour speed`. Read at run time from the working directory
/// (the repository's root, where `cargo test` and the GPU scripts run), so the test builds before the
/// reference exists. Made on the GPU machine with `MPM_WRITE_REFERENCE=tests/reference` (see
/// [`surface_frame`]).
const SURFACE_REFERENCE: &str = "tests/reference/dam-break-30-surface-480x270.png";

/// Frame 30 of the dam break drawn as a surface through `transfer`, checked for water and for GPU
/// times per pass. With `MPM_WRITE_REFERENCE=DIR` it is also written to DIR (never over a file).
fn surface_frame(transfer: Transfer) -> ImageStats {
    let dir = tempfile::tempdir().expect("temp dir");
    let report = common::render_logged(RenderOptions {
        size: [480, 270],
        mode: DrawMode::Surface,
        transfer,
        ..common::render_options("dam-break", BackendKind::Cuda, 30, dir.path())
    });
    let expected_path = match transfer {
        Transfer::Interop => "CUDA-GL interop",
        Transfer::HostCopy => "host copy + glBufferSubData",
    };
    assert_eq!(report.path, expected_path);
    common::assert_surface_passes_timed(&report.timings.gpu_passes_ms);
    let path = dir.path().join("frame-00030.png");
    let image = Image::read_png(&std::fs::read(&path).expect("frame 30 written")).expect("PNG");
    // Water, whatever the reference says: clearly blue pixels over a good part of the frame.
    let blue = common::water_fraction(&image);
    println!("blue (water) pixels: {:.1}%", 100.0 * blue);
    assert!(blue > 0.05, "hardly any water visible: {:.2}%", 100.0 * blue);
    let name = std::path::Path::new(SURFACE_REFERENCE)
        .file_name()
        .expect("a file name");
    write_reference_if_asked(&path, &name.to_string_lossy());
    image.stats()
}

/// With `MPM_WRITE_REFERENCE=DIR`, copies the rendered `frame` to DIR/`name`, never over a file: how
/// a reference frame is made (on the GPU machine; look at it before committing it).
fn write_reference_if_asked(frame: &std::path::Path, name: &str) {
    let Some(out) = std::env::var_os("MPM_WRITE_REFERENCE") else {
        return;
    };
    let target = std::path::Path::new(&out).join(name);
    if target.exists() {
        println!("{} exists: not replaced", target.display());
    } else {
        std::fs::copy(frame, &target).expect("writing the reference");
        println!("wrote the reference frame {}", target.display());
    }
}

fn surface_reference() -> ImageStats {
    let bytes = std::fs::read(SURFACE_REFERENCE).unwrap_or_else(|e| {
        panic!(
            "the surface's reference frame {SURFACE_REFERENCE} cannot be read ({e}; working directory {}). \
             Run the tests from the repository's root; if the file is missing, make it on the GPU machine \
             with MPM_WRITE_REFERENCE=tests/reference, look at it, and commit it",
            std::env::current_dir().map_or("unknown".into(), |d| d.display().to_string())
        )
    });
    Image::read_png(&bytes).expect("reference PNG").stats()
}

fn surface_render_matches_reference() {
    assert_close_to_reference(&surface_frame(Transfer::Interop), &surface_reference());
}

/// The host copy feeds the same surface: the same statistics as the reference (made by interop).
fn surface_render_through_host_copy_matches_reference() {
    assert_close_to_reference(&surface_frame(Transfer::HostCopy), &surface_reference());
}

/// A preset on the CUDA solver, in a headless GL context of `size`, with the surface draw's settings
/// and a camera framing its fluid region: what the checks that feed and draw a frame themselves
/// start from.
struct SurfaceStage {
    headless: HeadlessGl,
    settings: RenderSettings,
    domain: (Vec3, Vec3),
    camera: OrbitCamera,
    sim: Simulation,
}

fn surface_stage(preset: &str, size: [u32; 2]) -> SurfaceStage {
    let headless = HeadlessGl::new(size[0], size[1]).expect("headless OpenGL");
    let scene = Scene::load(preset).expect("preset");
    let settings =
        RenderSettings::for_scene(&scene, DrawMode::Surface, Colouring::Speed, None).expect("settings");
    let (lo, hi) = scene.fluid_region();
    let domain = (lo.as_vec3(), hi.as_vec3());
    let camera = settings.framing(domain.0, domain.1, Viewport::full(size));
    let solver = CudaSolver::new(&scene, CudaOptions::default()).expect("CUDA solver");
    SurfaceStage {
        headless,
        settings,
        domain,
        camera,
        sim: Simulation::new(scene, Box::new(solver)),
    }
}

/// The surface's thickness pass two ways on the same particles: summed by CUDA from the particles the
/// interop feed wrote, and blended by GL from the host copy's. GL blends into half floats, rounding
/// at every splat it adds (11 bits: 0.05 % each); CUDA sums exactly and rounds once. So the two may
/// differ texel by texel by a fraction of a percent, and must cover the same texels and hold the same
/// water.
fn thickness_summed_by_cuda_is_the_thickness_gl_blends() {
    let size = [960, 540];
    let SurfaceStage {
        headless,
        settings,
        domain,
        camera,
        mut sim,
    } = surface_stage("dam-break", size);
    for _ in 0..30 {
        sim.step_frame().expect("step");
    }
    let mut renderer = Renderer::new(headless.gl().clone()).expect("renderer");
    let mut thickness = |transfer: Transfer| {
        let mut feed = ParticleFeed::new(transfer);
        let fed = feed
            .update(&mut sim, &mut renderer, settings.colouring)
            .expect("feed");
        renderer
            .draw(Viewport::full(size), &camera, &settings, fed.slots, domain)
            .expect("draw");
        headless.finish();
        let (texture_size, texels) = renderer.read_thickness().expect("a thickness texture");
        let by_cuda = renderer.thickness_by_cuda();
        feed.release();
        (texture_size, texels, by_cuda)
    };
    let (cuda_size, cuda, by_cuda) = thickness(Transfer::Interop);
    assert!(by_cuda, "the interop feed's frame was not splatted by CUDA");
    let (gl_size, gl, by_cuda) = thickness(Transfer::HostCopy);
    assert!(!by_cuda, "the host copy's frame was splatted by CUDA");
    assert_eq!(cuda_size, gl_size);
    renderer.destroy();

    for channel in 0..2 {
        let covered = |t: &[[f32; 2]]| t.iter().filter(|t| t[channel] > 0.0).count();
        let only_one = cuda
            .iter()
            .zip(&gl)
            .filter(|(a, b)| (a[channel] > 0.0) != (b[channel] > 0.0))
            .count();
        let sum = |t: &[[f32; 2]]| t.iter().map(|t| f64::from(t[channel])).sum::<f64>();
        let (sum_cuda, sum_gl) = (sum(&cuda), sum(&gl));
        let mean_abs_difference = cuda
            .iter()
            .zip(&gl)
            .map(|(a, b)| f64::from((a[channel] - b[channel]).abs()))
            .sum::<f64>()
            / covered(&gl).max(1) as f64;
        let mean = sum_gl / covered(&gl).max(1) as f64;
        println!(
            "channel {channel}: {} texels covered by CUDA, {} by GL, {only_one} by one only; sums {sum_cuda:.4} \
             and {sum_gl:.4}; mean |difference| {mean_abs_difference:.3e} of a mean {mean:.3e} over covered texels",
            covered(&cuda),
            covered(&gl)
        );
        assert!(
            covered(&gl) > cuda.len() / 20,
            "hardly any water in the thickness texture: {} of {} texels",
            covered(&gl),
            cuda.len()
        );
        assert!(
            only_one as f64 <= 1e-3 * covered(&gl) as f64,
            "{only_one} texels covered by one path only"
        );
        assert!(
            (sum_cuda - sum_gl).abs() <= 5e-3 * sum_gl,
            "the water differs: {sum_cuda} against {sum_gl}"
        );
        assert!(
            mean_abs_difference <= 1e-2 * mean,
            "texels differ by {mean_abs_difference} on average"
        );
    }
}

/// A scene with solids on CUDA: the feed writes each slot's material row after its attributes, by a
/// second launch of the render kernel into the mapped buffer (interop) or through the host, and both
/// hold the solver's own rows; the surface, drawing the solids apart, has GL splat the thickness (CUDA
/// would count the solids in), although the jelly drop's 467,200 particles are enough for CUDA's.
fn solid_rows_arrive_through_interop_and_host_copy() {
    let size = [320, 180];
    let SurfaceStage {
        headless,
        settings,
        domain,
        camera,
        mut sim,
    } = surface_stage("jelly-drop", size);
    sim.step_frame().expect("step");
    let expected = sim.solver_mut().read_particles().expect("read back");
    let mut renderer = Renderer::new(headless.gl().clone()).expect("renderer");
    for (transfer, path) in [
        (Transfer::Interop, "CUDA-GL interop"),
        (Transfer::HostCopy, "host copy + glBufferSubData"),
    ] {
        let mut feed = ParticleFeed::new(transfer);
        let fed = feed
            .update(&mut sim, &mut renderer, settings.colouring)
            .expect("feed");
        assert_eq!(feed.path(), path);
        let rows = renderer.read_material_rows(fed.slots);
        assert_eq!(rows.len(), fed.slots, "{path}: a row per slot");
        for (slot, row) in rows.iter().enumerate() {
            assert_eq!(
                row[3],
                f32::from(expected.material[slot]),
                "{path}: slot {slot}'s row"
            );
        }
        renderer
            .draw(Viewport::full(size), &camera, &settings, fed.slots, domain)
            .expect("draw");
        headless.finish();
        assert!(
            !renderer.thickness_by_cuda(),
            "{path}: CUDA splatted the thickness of a scene with solids"
        );
        println!("{path}: the {} slots' rows are the solver's", fed.slots);
        feed.release();
    }
    renderer.destroy();
}
