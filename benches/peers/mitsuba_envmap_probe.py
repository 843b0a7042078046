"""Measures how Mitsuba 3 evaluates a latitude-longitude environment map: writes an 8 x 4 probe image
whose texel (i, j) holds (i + 1, j + 1, 100 j + i + 1), loads it as an `envmap` and prints the radiance
Mitsuba's `eval` returns at chosen (u, v). The values are the reference of
crates/scene/src/envmap.rs's `radiance_matches_mitsuba_at_probe_points` (texel centres at
u = (i + 1/2)/w, wrapping; rows at v = j/(h - 1); u = atan2(x, -z)/2pi, v = acos(y)/pi).

    pip install mitsuba numpy && python3 benches/peers/mitsuba_envmap_probe.py
"""
import mitsuba as mi, numpy as np, math
mi.set_variant('scalar_rgb')
w,h=8,4
img=np.zeros((h,w,3),dtype=np.float32)
for j in range(h):
    for i in range(w):
        img[j,i]=[i+1, j+1, 100*j+i+1]
mi.Bitmap(img).write('probe.exr')
e=mi.load_dict({'type':'envmap','filename':'probe.exr'})
def ev(d):
    si=mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(-np.array(d))
    return np.array(e.eval(si))
def dirof(u,v):
    th=v*math.pi; ph=2*math.pi*u
    return [math.sin(th)*math.sin(ph), math.cos(th), -math.sin(th)*math.cos(ph)]
for (u,v) in [(0.0,0.0),(0.5/8,0.5/4),(1/8,1/4),(0.25,0.5),(0.3,0.6),(0.99,0.9),(0.0625,0.125),(0.0,0.5),(0.999,0.5)]:
    print(u,v, ev(dirof(u,v)))
