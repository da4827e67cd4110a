//! The viewer's GPU paths on an NVIDIA machine, headless: CUDA-OpenGL interop through an EGL device
//! context, and the push kernel against the CPU formula. Every test prints `skipped: <reason>` and
//! passes where there is no CUDA device or no EGL device with OpenGL.

use glam::Vec3;
use mpm::cuda::interop::GlBufferResource;
use mpm::cuda::{library, CudaOptions, CudaSolver};
use mpm::render::headless::HeadlessGl;
use mpm::render::Renderer;
use mpm::sim::cpu::CpuSolver;
use mpm::sim::{ColourBy, Push, Scene, Simulation, Solver};

/// A CUDA device and a headless GL context, or `None` after printing why not.
fn cuda_and_gl(test: &str) -> Option<HeadlessGl> {
    if let Err(why) = library::device_available() {
        println!("{test}: skipped: {why:#}");
        return None;
    }
    match HeadlessGl::new(64, 64) {
        Ok(gl) => Some(gl),
        Err(why) => {
            println!("{test}: skipped: no headless OpenGL: {why:#}");
            None
        }
    }
}

#[test]
fn interop_round_trip_through_gl() {
    let Some(headless) = cuda_and_gl("interop_round_trip_through_gl") else {
        return;
    };
    println!("OpenGL: {}", headless.description);
    let scene = Scene::load("drop").expect("preset");
    let n = scene.num_particles;
    let rest_density = scene.material.rest_density;
    let solver = CudaSolver::new(&scene, CudaOptions::default()).expect("CUDA solver");
    let mut sim = Simulation::new(scene, Box::new(solver));
    // A few frames, so speeds differ from particle to particle.
    for _ in 0..5 {
        sim.step_frame().expect("step");
    }
    let expected = sim.solver_mut().read_particles().expect("read back");
    let cuda = sim
        .solver_mut()
        .as_any_mut()
        .downcast_mut::<CudaSolver>()
        .expect("a CUDA solver");

    let mut renderer = Renderer::new(headless.gl().clone()).expect("renderer");
    renderer.ensure_capacity(n);
    for round in 0..2 {
        // Register, map, write with the kernel, unmap; twice, so release and re-registration work.
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
        let colour_by = if round == 0 {
            ColourBy::Speed
        } else {
            ColourBy::Density
        };
        unsafe { cuda.write_render_attributes_raw(mapped.ptr, colour_by, rest_density) }.expect("kernel");
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
            let want = colour_by.value(expected.v[i], expected.rho[i], rest_density);
            worst = worst.max((v[3] - want).abs() / want.abs().max(1e-3));
        }
        println!("round {round} ({colour_by:?}): {n} particles, worst relative error {worst:.2e}");
        assert!(worst < 1e-5, "colour quantity off by {worst}");
    }
    renderer.destroy();
}

#[test]
fn push_agrees_between_cpu_and_cuda() {
    if let Err(why) = library::device_available() {
        println!("push_agrees_between_cpu_and_cuda: skipped: {why:#}");
        return;
    }
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
