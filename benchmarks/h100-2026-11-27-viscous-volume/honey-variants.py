def honey(name, dx, size, plate_top, nozzle_y, radius, speed, mu, frames_note=""):
    sx, sy, sz = size
    res = [round(sx/dx), round(sy/dx), round(sz/dx)]
    cx, cz = sx/2, sz/2
    s=f'''name = "{name}"
[domain]
size = [{sx}, {sy}, {sz}]
resolution = {res}
[material]
name = "honey"
colour = [0.85, 0.55, 0.08]
rest_density = 1400.0
sound_speed = 8.0
viscosity = {mu}
[time_step]
cfl = 0.4
max_substeps = 100000
[particles]
capacity = 200000
[[collider]]
shape = "box"
center = [{cx}, {plate_top-0.05}, {cz}]
size = [{sx*0.6}, 0.1, {sz*0.6}]
boundary = "stick"
[[emitter]]
shape = "disc"
center = [{cx}, {nozzle_y}, {cz}]
normal = [0.0, -1.0, 0.0]
radius = {radius}
speed = {speed}
particles_per_cell = 8
'''
    open(name+'.toml','w').write(s)
honey('h1', 0.005, (0.2,0.3,0.2), 0.05, 0.20, 0.0125, 0.1, 50.0)
honey('h2', 0.0025, (0.15,0.2,0.15), 0.03, 0.13, 0.00625, 0.1, 30.0)
honey('h3', 0.0025, (0.15,0.2,0.15), 0.03, 0.13, 0.00625, 0.1, 100.0)
honey('h4', 0.005, (0.3,0.4,0.3), 0.10, 0.25, 0.0125, 0.1, 100.0)
