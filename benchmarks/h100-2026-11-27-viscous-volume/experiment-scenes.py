import sys
def film(name, cells, n=0.5, K=221.0, ceiling=400.0, floor_visc=0.0, c=10.0, extra=""):
    h=0.05; dx=h/cells; k=cells//10; floor=0.02
    s=f'''name = "{name}"
[domain]
size = [0.22, 0.09, {8*dx}]
resolution = [{44*k}, {18*k}, 8]
[material]
law = "power-law"
rest_density = 1000.0
sound_speed = {c}
consistency = {K}
flow_index = {n}
max_viscosity = {ceiling}
min_viscosity = {floor_visc}
[solver]
gravity = [9.81, 0.0, 0.0]
{extra}
[time_step]
cfl = 0.4
max_substeps = 1000000
[[collider]]
shape = "box"
center = [0.11, {floor-0.5*dx-0.1}, {4*dx}]
size = [0.42, 0.2, 0.24]
boundary = "stick"
[[block]]
min = [0.03, {floor}, {dx}]
max = [0.19, {floor+h}, {6*dx}]
particles_per_cell = 8
'''
    open(name+'.toml','w').write(s)
film('f10', 10); film('f20', 20); film('f40', 40)
film('f20c4000', 20, ceiling=4000.0)
film('f20s40', 20, c=40.0)
film('f20binned', 20, extra='pipeline = "binned"')
film('f20n15', 20, n=1.5, K=45.2, ceiling=150.0, floor_visc=1.0)
film('f10c4000', 10, ceiling=4000.0)
film('f10s40', 10, c=40.0)
def slump(name, dx, ceiling, K=10.0):
    k=round(0.05/dx)
    s=f'''name = "{name}"
[domain]
size = [2.0, 1.2, {8*dx}]
resolution = [{40*k}, {24*k}, 8]
[material]
law = "herschel-bulkley"
rest_density = 1000.0
sound_speed = 20.0
consistency = {K}
flow_index = 1.0
yield_stress = 800.0
max_viscosity = {ceiling}
[time_step]
cfl = 0.4
max_substeps = 1000000
[[collider]]
shape = "box"
center = [1.0, {0.5*dx-0.1}, {4*dx}]
size = [2.2, 0.2, 0.6]
boundary = "stick"
[[block]]
min = [0.05, {dx}, {dx}]
max = [0.55, {dx+1.0}, {6*dx}]
particles_per_cell = 8
'''
    open(name+'.toml','w').write(s)
slump('b5c3000', 0.05, 3000.0); slump('b5c60000', 0.05, 60000.0)
slump('b25c3000', 0.025, 3000.0); slump('b25c60000', 0.025, 60000.0)
