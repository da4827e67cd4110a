// The host/device contract's items: every struct the kernels receive or share with the host, and
// every constant both sides name. Written once, here: `src/contract/mod.rs` expands them into Rust
// items, and build.rs into the header the kernels include as "contract.cuh" (with `static_assert`s
// of every size and field offset that Rust computed). A constant's Rust type is its C type: `u32`
// is written `4u`, `i32` as a plain `4`, `f32` as `1.0f`, so the kernels compile exactly as they did
// with hand-written macros.
//
// To add a field: add it here (keeping every struct free of implicit padding: bytemuck's Pod refuses
// one), and use it on both sides; nothing else restates it.

device_structs! {
    /// One liquid's constitutive law, a row of the scene's material table (docs/physics.md,
    /// "Materials"): the one owner of these values. kernels/material.cuh and src/sim/material.rs
    /// compute the law from it.
    struct Material {
        /// rho0, kg/m^3.
        rest_density: f32,
        /// Tait stiffness k, Pa.
        eos_stiffness: f32,
        /// Tait exponent gamma.
        eos_power: f32,
        /// `LAW_NEWTONIAN`: the dynamic viscosity mu, Pa s. `LAW_POWER_LAW` and
        /// `LAW_HERSCHEL_BULKLEY`: the consistency K, Pa s^n. `LAW_CARREAU_YASUDA`: the zero-shear
        /// viscosity mu_0, Pa s.
        viscosity: f32,
        /// p_min, Pa: pressure is clamped from below so that the free surface does not pull itself
        /// together.
        pressure_floor: f32,
        /// m_p, kg: rho0 dx^3 / particles-per-cell, so the initial packing is at rest density.
        particle_mass: f32,
        /// `LAW_*`: how the viscosity follows the shear rate.
        law: u32,
        /// The flow index n of the power law, Carreau-Yasuda and Herschel-Bulkley (1: Newtonian).
        flow_index: f32,
        /// Herschel-Bulkley: the yield stress tau_y, Pa.
        yield_stress: f32,
        /// The effective viscosity's ceiling, Pa s (every law but the Newtonian): the bi-viscous
        /// regularisation of the yield stress, and the bound of a power law at rest. It sets the
        /// explicit viscous limit on the substep.
        max_viscosity: f32,
        /// The effective viscosity's floor, Pa s: the power law's at high shear rates, and
        /// Carreau-Yasuda's infinite-shear viscosity mu_inf.
        min_viscosity: f32,
        /// Carreau-Yasuda: the relaxation time lambda, s.
        relaxation_time: f32,
        /// Carreau-Yasuda: the transition exponent a.
        transition_exponent: f32,
        /// Solids (`law >= FIRST_SOLID_LAW`): the Lame shear modulus mu = E / (2 (1 + nu)), Pa.
        /// `LAW_HERSCHEL_BULKLEY`: the elastic regularisation's shear modulus G (0: bi-viscous).
        shear_modulus: f32,
        /// Solids: the Lame first parameter lambda = E nu / ((1 + nu) (1 - 2 nu)), Pa.
        lame_lambda: f32,
        /// `LAW_SNOW`: the critical compression theta_c (singular values of the elastic part of F
        /// are clamped to [1 - theta_c, 1 + theta_s]).
        critical_compression: f32,
        /// `LAW_SNOW`: the critical stretch theta_s.
        critical_stretch: f32,
        /// `LAW_SNOW`: the hardening coefficient xi (mu and lambda times exp(xi (1 - J_p))).
        hardening: f32,
        /// `LAW_SAND`: the Drucker-Prager coefficient alpha = sqrt(2/3) 2 sin(phi) / (3 - sin(phi)),
        /// phi the friction angle.
        friction_alpha: f32,
        /// `LAW_SAND`: the cohesion, as the Hencky strain of isotropic tension the sand bears
        /// before it yields (0: cohesionless).
        cohesion: f32,
        _pad: [u32; 4],
    }

    /// What every kernel gets by value, its first argument: solver settings, grid shape, the step
    /// size and the size of the material table (the table itself is in the kernels' constant memory,
    /// `material_table` in kernels/material.cuh). Part of `sim::Params`, which `Scene::params`
    /// writes.
    struct KernelParams {
        /// m/s^2.
        gravity: [f32; 3],
        /// The substep, s. Set by the time-step policy before every frame.
        dt: f32,
        /// Grid nodes per axis; node (i, j, k) sits at (i, j, k) dx and is stored at i + rx (j + ry k).
        grid_res: [u32; 3],
        /// Node spacing, m.
        dx: f32,
        inv_dx: f32,
        /// Outer node layers in which velocity into the wall is removed (free slip; fluid may leave).
        boundary_band: u32,
        /// Time constant of the soft wall, s; 0 turns it off.
        soft_wall_tau: f32,
        num_particles: u32,
        /// `SCATTER_FLOAT` or `SCATTER_FIXED_POINT` (`ScatterMode::code()`).
        scatter_mode: u32,
        /// Fixed-point units per kg of grid mass (the fixed-point scatter and the binned tiles).
        fixed_mass_scale: f32,
        /// Fixed-point units per kg m/s of grid momentum (likewise; Simulation::momentum_scale).
        fixed_momentum_scale: f32,
        /// Mirror planes of the walls, in nodes: where fluid rests against the low walls (the same on
        /// every axis) and the high walls. The grid gains the mass and momentum of a mirror-image fluid
        /// beyond each wall (`cpu::mirror_walls`, kernels/mirror_walls.cu), so particles at a wall are
        /// not read as a free surface. 0 turns the mirror off (never 0 when on: the fluid region starts
        /// at node 1).
        wall_mirror_lo: u32,
        wall_mirror_hi: [u32; 3],
        /// How a particle's density is estimated (`DensityRule::code()`): `DENSITY_GATHERED` (the
        /// report's scheme) or `DENSITY_ADVECTED` (the fused pipeline's one particle pass).
        density_rule: u32,
        /// 1 where the materials' rest densities differ: each particle's density is gathered from
        /// the grid's volume (the particles' stencil weights summed in `VOLUME_UNITS_PER_WEIGHT`)
        /// times its own particle mass, never from the grid's mass, which mixes the liquids' masses
        /// where they meet (`sim::params::gathers_volume`).
        volume_density: u32,
        /// Rows of the material table in use (`sim::Params::materials`): 1 for a scene of one
        /// material, whose kernels take row 0 without reading a particle's index.
        material_count: u32,
        /// The box of nodes this GPU's grid holds, `box_lo .. box_lo + box_res` per axis, node (i,
        /// j, k) stored at (i - box_lo.x) + box_res.x ((j - box_lo.y) + box_res.y (k - box_lo.z)):
        /// one GPU holds the whole grid (0, `grid_res`), a rank its slab and ghost planes
        /// (src/cuda/grid.rs `GridBox`). Last, and never saved: where a GPU holds its grid is no
        /// part of a run's state (src/checkpoint.rs writes the words before it).
        box_lo: [u32; 3],
        box_res: [u32; 3],
    }

    /// What the kernels count and reduce between substep choices; the host reads it back once per
    /// choice (src/cuda/counters.rs).
    struct StepCounters {
        /// Bits of the largest rho (non-negative floats order like their bits).
        max_density_bits: u32,
        /// Bits of the largest |v|.
        max_speed_bits: u32,
        /// Fixed-point contributions or sums out of range (must stay 0).
        fixed_overflows: u32,
        /// Bits of the largest c(rho_p) + |v_p| of one particle.
        max_signal_bits: u32,
        /// Binned pipeline: a particle's stencil left its bin's reach (bins.cu).
        rebin_needed: u32,
        /// Binned pipeline: particles scattered past their tile, by global atomics.
        tile_misses: u32,
        /// Particles the colliders' backstop put back on a surface (colliders.cuh).
        backstop_pushes: u32,
        _pad: u32,
    }

    /// The particle lifecycle's free stack and what it did since the run began (kernels/lifecycle.cu,
    /// src/cuda/lifecycle.rs).
    struct FlowCounters {
        /// Slots on the free stack.
        free_count: u64,
        /// free[..sorted] is in canonical order (settle_free).
        sorted: u64,
        emitted: u64,
        drained: u64,
        /// Nozzle points that found the stack empty.
        exhausted: u64,
        /// Nozzle points whose last particle had not moved clear.
        blocked: u64,
    }

    /// One collider at one instant, as every backend reads it (src/sim/colliders.rs,
    /// kernels/colliders.cuh).
    struct ColliderState {
        /// `COLLIDER_*`.
        kind: u32,
        /// `BOUNDARY_*`.
        boundary: u32,
        /// Coulomb coefficient (friction boundary only).
        friction: f32,
        /// Nodes with a signed distance below this, m, are constrained (`BAND_CELLS` dx).
        band: f32,
        /// World-from-local rotation, row-major: world = rotation * local + center.
        rotation: [f32; 9],
        /// m.
        center: [f32; 3],
        /// Velocity of the centre, m/s.
        velocity: [f32; 3],
        /// rad/s, world frame; a point x moves at velocity + angular_velocity x (x - center).
        angular_velocity: [f32; 3],
        /// Box: half extents. Sphere: radius in `size[0]`. Capsule, cylinder: radius in `size[0]`,
        /// half length (along local y) in `size[1]`. Mesh: unused.
        size: [f32; 3],
        /// Mesh: the local position of SDF sample (0, 0, 0).
        sdf_origin: [f32; 3],
        /// Mesh: SDF samples per axis (x fastest).
        sdf_dims: [u32; 3],
        /// Mesh: distance between SDF samples, m.
        sdf_spacing: f32,
        /// Mesh: index of the first sample in the frame's SDF buffer.
        sdf_offset: u32,
        /// Radius of a ball about the centre that holds the shape, m, with a margin for rounding: a
        /// point farther than this (plus the band) is skipped without evaluating the shape.
        reach: f32,
        /// A rigid body's collider: 1 + the body's index, whose impulse accumulator the grid update
        /// adds to what this collider's boundary took from the nodes. 0: a collider that feels nothing.
        body: u32,
        _pad: u32,
    }

    /// A rigid body that the liquid moves and that moves the liquid (src/sim/bodies.rs,
    /// kernels/bodies.cu): stepped once a substep from the impulse its boundary gave the grid's nodes.
    /// Double precision: one thread steps it, and its pose accumulates over thousands of substeps.
    struct RigidBody {
        /// World position of the body's frame (the collider's `center`), m.
        center: [f64; 3],
        /// World-from-body rotation, a unit quaternion (x, y, z, w).
        orientation: [f64; 4],
        /// Velocity of the centre of mass, m/s.
        velocity: [f64; 3],
        /// rad/s, world frame.
        angular_velocity: [f64; 3],
        /// The centre of mass in the body's frame, m.
        centroid: [f64; 3],
        /// 1 / mass, 1/kg.
        inv_mass: f64,
        /// Inertia about the centre of mass in the body's frame, kg m^2, row-major; and its inverse.
        inertia: [f64; 9],
        inv_inertia: [f64; 9],
        /// A hinge: a point of its axis (world, m) and the unit axis; a zero axis for a free body.
        hinge_point: [f64; 3],
        hinge_axis: [f64; 3],
        /// Coulomb coefficient of its contacts (with another body: the two coefficients' geometric
        /// mean).
        contact_friction: f64,
        /// Its contact features: `[first_feature, first_feature + num_features)` of the list; the
        /// first `num_corners` of them meet the walls, all of them meet colliders and bodies.
        first_feature: u32,
        num_features: u32,
        /// Its collider's slot in the collider states, where each substep's pose is written.
        slot: u32,
        num_corners: u32,
    }

    /// The planes that hold the rigid bodies in the tank: where the liquid rests against the walls
    /// (the fluid region), m.
    struct BodyWalls {
        lo: [f64; 3],
        hi: [f64; 3],
    }

    /// A point of a body that may touch something (body frame), swept by a ball of `radius`: a box's
    /// corner or a point of its edges (radius 0), a sphere's centre (its radius), a capsule's end.
    struct ContactFeature {
        point: [f64; 3],
        radius: f64,
    }

    /// A rigid body over its substep (step_bodies' scratch, one per body): its centre of mass at the
    /// start, its new velocities, what contacts see of its mass (none for a hinged body: a moving
    /// obstacle to the others), and the pseudo-velocities that push it out of overlaps.
    struct BodyMotion {
        com: [f64; 3],
        velocity: [f64; 3],
        angular_velocity: [f64; 3],
        inv_mass: f64,
        /// World frame, row-major.
        inv_inertia: [f64; 9],
        push_velocity: [f64; 3],
        push_angular_velocity: [f64; 3],
    }

    /// A contact of body `body`'s feature found this substep (step_bodies' scratch,
    /// `MAX_BODY_CONTACTS` per body): the touching point relative to the body's centre of mass and
    /// to its partner's, the normal out of the partner, how deep the feature's ball is in it (negative:
    /// the gap between them), the Coulomb coefficient, and the impulses given so far.
    struct BodyContact {
        arm: [f64; 3],
        partner_arm: [f64; 3],
        normal: [f64; 3],
        /// A partner that is no body (`NO_BODY`): its velocity at the point (zero for a wall).
        partner_velocity: [f64; 3],
        friction_impulse: [f64; 3],
        depth: f64,
        friction: f64,
        normal_impulse: f64,
        push_impulse: f64,
        body: u32,
        /// The other body's index, or `NO_BODY`.
        partner: u32,
    }

    /// The viewer's mouse push, applied once (an impulse) between frames (src/sim/push.rs,
    /// kernels/push.cu).
    struct Push {
        /// A point on the ray (the camera eye), m.
        origin: [f32; 3],
        /// Particles closer than this to the ray are pushed, m.
        radius: f32,
        /// Unit direction of the ray.
        direction: [f32; 3],
        _pad0: f32,
        /// Velocity change at the ray itself, m/s; it falls off smoothly to zero at `radius`.
        delta_v: [f32; 3],
        _pad1: f32,
    }

    /// One fluid body of the device spawn (src/cuda/spawn.rs, kernels/spawn.cu).
    struct SpawnBody {
        /// Lattice index range visited, `[lo, hi)` per axis; for a block also its containment test.
        range_lo: [i64; 3],
        range_hi: [i64; 3],
        /// Sphere: its centre, m.
        center: [f64; 3],
        /// Sphere: radius * radius, rounded as the host rounds it.
        radius_sq: f64,
        velocity: [f32; 3],
        /// `BODY_BLOCK` or `BODY_SPHERE`.
        kind: u32,
        /// v.w of its particles: the bits of its material's row.
        material_tag: f32,
        /// Its material's rest density: its particles' first density, kg/m^3.
        rest_density: f32,
        /// Offset of this body's range in the list of all candidates.
        first_candidate: u64,
    }

    /// One block's partial statistics (kernels/stats.cu, src/cuda/stats.rs).
    struct StatsPartial {
        /// J.
        kinetic_energy: f64,
        /// m, for the centre of mass.
        position_sum: [f64; 3],
        density_ratio_sum: f64,
        /// m/s.
        max_speed: f32,
        density_ratio_min: f32,
        density_ratio_max: f32,
        count: u32,
    }

    /// The camera of the surface's thickness splats (kernels/thickness.cu): what the GL pass's
    /// shader gets as uniforms (src/render/shaders/surface_particle.vert).
    struct SplatCamera {
        /// The view matrix's first three rows, row-major: view space = rows (x, y, z, 1), m.
        view: [f32; 12],
        /// The projection matrix, row-major.
        projection: [f32; 16],
        /// The sphere's radius, m.
        radius: f32,
        /// Texels per metre at unit depth.
        pixels_per_metre: f32,
        /// The smallest splat radius, texels.
        min_splat_px: f32,
        /// One particle's volume, m^3.
        particle_volume: f32,
        /// The thickness texture's size, texels.
        width: u32,
        height: u32,
    }

    /// One listed chunk of a bin: the bin's node block and the chunk's range in the bin order
    /// (kernels/bins.cu writes them, the tiled passes walk them).
    struct BinEntry {
        bin: u32,
        start: u32,
        count: u32,
        _pad: u32,
    }
}

device_constants! {
    /// `Params::scatter_mode`: float atomics.
    SCATTER_FLOAT: u32 = 0;
    /// `Params::scatter_mode`: fixed-point integer atomics.
    SCATTER_FIXED_POINT: u32 = 1;

    /// `Params::density_rule`: rho_p re-estimated from the grid mass at the particle's new position,
    /// which needs the mass scattered before the momentum (two particle passes a substep).
    DENSITY_GATHERED: u32 = 0;
    /// `Params::density_rule`: rho_p gathered from the grid mass at the particle's previous position
    /// with its velocity, and carried over the substep by the velocity divergence (one pass).
    DENSITY_ADVECTED: u32 = 1;
    /// `DENSITY_ADVECTED`: the largest relative volume change a particle's density is carried over
    /// in one substep (`DensityRule::advect`).
    MAX_VOLUME_CHANGE: f32 = 0.1;
    /// `Params::volume_density`: the fixed-point units of one stencil weight in the grid's volume
    /// (2^22: a weight is resolved to 2.4e-7; a shared tile node's 32-bit sum holds 512 weights, a
    /// chunk of 1,200 particles, and a node's 64-bit sum 2^41).
    VOLUME_UNITS_PER_WEIGHT: f32 = 4194304.0;

    /// The most rows of a scene's material table (`sim::Params::materials`).
    MAX_MATERIALS: u32 = 8;
    /// `Material::law`: a constant viscosity.
    LAW_NEWTONIAN: u32 = 0;
    /// `Material::law`: mu = K gammadot^(n - 1), within [min_viscosity, max_viscosity].
    LAW_POWER_LAW: u32 = 1;
    /// `Material::law`: mu = mu_inf + (mu_0 - mu_inf) (1 + (lambda gammadot)^a)^((n - 1) / a),
    /// within [min_viscosity, max_viscosity].
    LAW_CARREAU_YASUDA: u32 = 2;
    /// `Material::law`: mu = min(max_viscosity, K gammadot^(n - 1) + tau_y / gammadot), the
    /// bi-viscous regularisation of a yield stress (Bingham where n = 1).
    LAW_HERSCHEL_BULKLEY: u32 = 3;
    /// `Material::law`: the first solid; every law from here on is a solid's, whose particles carry
    /// a deformation gradient (`sim::Deformation`) and scatter its stress instead of a pressure.
    FIRST_SOLID_LAW: u32 = 4;
    /// `Material::law`: an elastic solid, fixed-corotated (Stomakhin et al. 2012):
    /// tau = 2 mu (F - R) F^T + lambda (J - 1) J I.
    LAW_FIXED_COROTATED: u32 = 4;
    /// `Material::law`: an elastic solid, Neo-Hookean: tau = mu (F F^T - I) + lambda ln(J) I.
    LAW_NEO_HOOKEAN: u32 = 5;
    /// `Material::law`: snow (Stomakhin et al. 2013): fixed-corotated with the elastic part's
    /// singular values clamped to [1 - theta_c, 1 + theta_s] and hardening exp(xi (1 - J_p)).
    LAW_SNOW: u32 = 6;
    /// `Material::law`: sand (Klar et al. 2016): Hencky-strain elasticity with a Drucker-Prager
    /// return mapping in log-strain space.
    LAW_SAND: u32 = 7;
    /// `LAW_SNOW`: the bounds of the hardening exp(xi (1 - J_p)), Taichi's mpm128's: compacted snow
    /// stiffens at most 5-fold (its wave speed, and so the substep, within sqrt(5) of the unhardened
    /// one), snow pulled apart keeps a tenth of its stiffness.
    SNOW_MIN_HARDENING: f32 = 0.1;
    SNOW_MAX_HARDENING: f32 = 5.0;
    /// The smallest |sigma| whose logarithm sand takes: a singular value crushed to zero, or inverted
    /// through it, reads as this stretch (a Hencky strain of -9.2) rather than ln 0 = -inf.
    SOLID_MIN_STRETCH: f32 = 1.0e-4;
    /// The smallest J whose logarithm the Neo-Hookean law takes, `SOLID_MIN_STRETCH` cubed.
    SOLID_MIN_VOLUME: f32 = 1.0e-12;
    /// Pa s: a Newtonian liquid this viscous or more, and every other law, scatters its viscous
    /// stress with its rest volume wherever it reads less than its rest density (docs/physics.md,
    /// "The viscous stress's volume"); thinner ones (water) with the volume it reads.
    VISCOUS_REST_VOLUME_FROM: f32 = 0.1;

    /// `ColliderState::kind`.
    COLLIDER_BOX: u32 = 0;
    COLLIDER_SPHERE: u32 = 1;
    COLLIDER_CAPSULE: u32 = 2;
    COLLIDER_CYLINDER: u32 = 3;
    COLLIDER_MESH: u32 = 4;
    /// Fixed-point units per N s of a rigid body's impulse accumulators (and per N m s of its
    /// angular impulse): 2^36, so a node's share down to 1e-9 N s keeps 7 digits and a body's sum
    /// reaches 1e8 N s.
    BODY_IMPULSE_UNITS: f32 = 68719476736.0;
    /// The most colliders a scene may have: the kernels walk them per node, so they stay few (and
    /// step_bodies holds that many bodies' motions in shared memory).
    MAX_COLLIDERS: u32 = 16;
    /// The rigid bodies' contacts (src/sim/colliders/bodies.rs, kernels/bodies.cu): the most one
    /// body resolves at once (a box on the floor has four with it, in a corner six; a box lying on
    /// another touches it at up to sixteen points of each, its corners and the points along its
    /// edges).
    MAX_BODY_CONTACTS: u32 = 32;
    /// Sequential-impulse sweeps over a substep's contacts: a stack of three boxes creeps 0.4 mm in
    /// half a second at 8, 0.03 mm at 16.
    BODY_CONTACT_SWEEPS: u32 = 16;
    /// The share of an overlap with another collider or body that a substep's push undoes: all of
    /// it at once overshoots where several contacts push the same body.
    BODY_PUSH_RATE: f64 = 0.2;
    /// Features this close to a wall or a collider are in contact, m: a resting body's contacts
    /// hold from substep to substep (and its friction with them) instead of flickering as it settles
    /// on and off the surface by rounding; the contact lets it close the gap, no more.
    BODY_CONTACT_MARGIN: f64 = 1.0e-4;
    /// How far inside its corner a feature meets other colliders, m: boxes of one depth side by side
    /// (a quasi-2D tank's) have their corners exactly in each other's face planes, where the
    /// distance reads zero whether they overlap or not; inset, a corner that overlaps is inside.
    /// Well above the rounding of a single-precision distance a metre from the origin, well below a
    /// cell.
    BODY_FEATURE_INSET: f64 = 1.0e-4;
    /// `BodyContact::partner` of a wall or a collider that is no body.
    NO_BODY: u32 = 0xffff_ffff;
    /// `ColliderState::boundary`.
    BOUNDARY_SLIP: u32 = 0;
    BOUNDARY_STICK: u32 = 1;
    BOUNDARY_FRICTION: u32 = 2;
    /// A nozzle's pipe (`[[emitter]] pipe_length`): nodes inside take its velocity, and particles
    /// pass through it (no backstop).
    BOUNDARY_PIPE: u32 = 3;

    // Position-based MPM (src/sim/pbmpm.rs, kernels/pbmpm.cu).
    /// How far past its target an iteration moves a liquid's volume (over-relaxation, as Lewin's
    /// reference implementation's default): the grid's averaging takes part of each correction back.
    /// At two iterations or more; none at one (`liquid_relaxation` in src/sim/pbmpm.rs says why).
    LIQUID_RELAXATION: f32 = 1.5;
    /// The same for a solid's shape target, before its stiffness weight (`stiffness_weight`).
    SOLID_RELAXATION: f32 = 1.5;
    /// How much of its smoothed volume error a liquid particle's volume bias (its pressure memory) gains
    /// a substep: the integral gain of its volume target (`PbmpmSolver`'s `liquid_volumes`). The bias
    /// must grow more slowly than the liquid's slowest compression wave settles: at 4 iterations a pool
    /// 10 cells deep settles at 0.02 and rings at 0.04, one 5 cells deep rings at 0.08.
    VOLUME_MEMORY_GAIN: f32 = 0.02;
    /// The weight of a liquid particle's smoothed volume error in its volume target, beside its own J,
    /// where the liquid is compressed (the target's proportional gain): a stiffer target, under which
    /// the memory also settles where it would ring without (a pool 10 cells deep at a memory gain of
    /// 0.02). Not in tension, where the particle's own J pulls it back already: a pull as strong drove
    /// the targets of the water splashing off the far wall of the pbmpm-dam-break preset towards no
    /// volume at all, and the run blew up within 0.6 s.
    VOLUME_ERROR_GAIN: f32 = 2.0;
    /// The volume bias is held within 0 and this: it remembers compression only (a liquid holds no
    /// tension), and no more than the liquid's own volume.
    MAX_VOLUME_BIAS: f32 = 1.0;
    /// How far a liquid particle's J moves a substep towards the volume the grid measures about it,
    /// where that measure holds (every stencil node full, `FULL_NODE_FILL`): the drift correction
    /// that keeps J its particles' real spacing.
    GRID_VOLUME_RATE: f32 = 0.1;
    /// A node counts as full where the rest volume of the particles about it (the walls' images
    /// included) is at least this much of its cell's: not at a free surface.
    FULL_NODE_FILL: f32 = 0.9;
    /// The drift correction's weight ramps from none where the particle's least full stencil node
    /// is `FULL_NODE_FILL_RAMP` / 2 below `FULL_NODE_FILL` to whole where it is as far above, and a
    /// node enters that least by its weight, fully from `FULL_NODE_WEIGHT` up, not at all at 0: a
    /// continuous rule, so that neither a node entering the stencil nor rounding (the GPU's
    /// fixed-point sums against the CPU's floats) switches the correction on for one run and off
    /// for another.
    FULL_NODE_FILL_RAMP: f32 = 0.1;
    FULL_NODE_WEIGHT: f32 = 1.0e-4;
    /// The liquids' viscosity sweep counts a neighbour node of mass m by m / (m + this times a
    /// cell's mass of the densest material): a node that particles barely reach, whose mass and
    /// displacement are a rounding's, fades out of it instead of entering with a whole vote.
    FADING_NODE_MASS: f32 = 1.0e-4;
    /// The smallest volume ratio J a liquid particle is given (a safety floor, reached only in a crush
    /// that the iterations could not resolve).
    MIN_LIQUID_VOLUME: f32 = 0.05;
    /// The singular values of a solid's F are held within these after each position-based
    /// integration: a safety clamp that keeps F invertible (its inverse maps the constraint's target
    /// back to a displacement).
    PBMPM_MIN_STRETCH: f32 = 0.1;
    PBMPM_MAX_STRETCH: f32 = 1.0e4;
    /// The fixed-point units of one cell's volume in the position-based grid's fill (2^40, as a
    /// cell's mass in the mass scatter's units: `Scene::fixed_point_scales`).
    PBMPM_CELL_VOLUME_UNITS: f32 = 1099511627776.0;

    /// x.w of a parked particle slot (0 for a live particle).
    PARKED_W: f32 = 1.0;
    /// No particle: a nozzle point that has not emitted yet.
    NO_PARTICLE: u32 = 0xffff_ffff;

    /// `SpawnBody::kind`.
    BODY_BLOCK: u32 = 0;
    BODY_SPHERE: u32 = 1;

    /// The quantity render_attributes writes into w (`ColourBy::code`).
    COLOUR_BY_SPEED: u32 = 0;
    COLOUR_BY_DENSITY: u32 = 1;
    COLOUR_BY_MATERIAL: u32 = 2;

    /// What mirror_walls mirrors (`MirrorQuantity`).
    MIRROR_MASS: u32 = 0;
    MIRROR_MOMENTUM: u32 = 1;
    /// The volume (kernels/volume.cu) of a scene whose rest densities differ.
    MIRROR_VOLUME: u32 = 2;

    /// Nodes per axis of a node block: a bin of the binned pipeline.
    NODE_BLOCK_EDGE: u32 = 4;
    /// Nodes of a node block: the threads of a launch per block.
    NODE_BLOCK_NODES: u32 = 64;
    /// Nodes of a tiled pass's shared tile: a node block, the stencil's reach and a halo of two per
    /// side, (4 + 2 + 2 * 2)^3.
    TILE_NODES: i32 = 1000;
    /// Threads of a tiled pass's block (its kernels' launch bounds).
    TILE_THREADS: i32 = 128;
    /// Slots of the work-count buffer: list lengths the passes read on the device, so no launch waits
    /// for the host to learn them.
    WORK_BINS: i32 = 0;
    /// The node-block list's two parts (kernels/tiles.cuh, `list_node_block`): the blocks no wall's
    /// mirror reaches, listed from the front, and those some wall's reach meets, from the back.
    WORK_NODE_BLOCKS: i32 = 1;
    /// CUDA blocks of grid_update_blocks done with their part of the node block list: the last one
    /// empties the part and sets this back to 0.
    WORK_NODE_BLOCKS_DONE: i32 = 2;
    WORK_WALL_NODE_BLOCKS: i32 = 3;
    /// The same for grid_update_wall_blocks and the wall blocks' part.
    WORK_WALL_NODE_BLOCKS_DONE: i32 = 4;

    /// Fixed-point units per metre of the thickness splats' sums (kernels/thickness.cu): 2^22, a
    /// splat's few centimetres are 10^5 units (rounding at 10^-5 of each), and a 32-bit sum holds
    /// 1,024 m.
    THICKNESS_UNITS_PER_METRE: f32 = 4194304.0;
    /// The largest thickness splat's radius, texels: half of the largest point sprite NVIDIA's GL
    /// draws (2047 px), which caps the GL pass's splats likewise.
    THICKNESS_MAX_SPLAT_PX: f32 = 1023.5;

    /// Keys past every bin's that bin_count spreads the parked slots over, a warp to a key: on one
    /// counter every warp's atomic would queue behind the others' (a rank parks half its slots).
    PARKED_KEYS: u32 = 32;
    /// Values each thread of scan_tiles scans.
    SCAN_ITEMS_PER_THREAD: i32 = 8;
    /// Threads per block of particle_stats.
    STATS_THREADS: i32 = 256;
}
