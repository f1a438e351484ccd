"""Pictures of an implicit surface written in GLSL (``lookalike.io.field_glsl``), sphere-traced
by a fragment shader we generate around the user's functions, in a real OpenGL context: the
same rays, steps, hit test, gradient normals, BSDF and point light as ``sphere_tracing`` (whose
constants it is given), so the two renderers of one field agree.
"""

from __future__ import annotations

import numpy as np
import torch

from ..io.field_glsl import FULL_SCREEN, MATERIAL_DEFAULTS, field_header
from ..io.glsl_context import USER_LINE, compile_program, gl_context, ours_after_user
from . import bsdf
from .camera import Camera
from .light import PointLight
from .pipeline import box_downsample
from ..asset.implicit import NORMAL_STEP
from .sphere_tracing import HIT_FRACTION, MAX_STEPS

TRACER_UNIFORMS = """uniform mat4 lk_inverse_mvp;
uniform vec3 lk_eye;
uniform vec3 lk_forward;
uniform float lk_proj11;
uniform vec2 lk_size;
uniform vec3 lk_light_position;
uniform vec3 lk_intensity;
uniform int lk_horizon;
uniform vec3 lk_lo;
uniform vec3 lk_hi;
uniform float lk_normal_step;
out vec4 lk_colour;
"""

TRACER_MAIN = """
const float LK_PI = 3.14159265358979;
vec3 lk_normal(vec3 p) {
    const vec3 e0 = vec3(1.0, -1.0, -1.0), e1 = vec3(-1.0, -1.0, 1.0), e2 = vec3(-1.0, 1.0, -1.0), e3 = vec3(1.0);
    float h = lk_normal_step;
    vec3 g = e0 * map(p + h * e0) + e1 * map(p + h * e1) + e2 * map(p + h * e2) + e3 * map(p + h * e3);
    return g / max(length(g), 1e-20);
}
vec3 lk_shade(vec3 kd, vec3 ks, vec3 n, vec3 v, vec3 l) {
    float roughness = clamp(ks.y, MIN_ROUGHNESS, 1.0);
    float alpha2 = roughness * roughness * roughness * roughness;
    vec3 h = normalize(v + l);
    float nl = dot(n, l), nv = dot(n, v), nh = dot(n, h), vh = dot(v, h);
    vec3 f0 = (DIELECTRIC_F0 * (1.0 - ks.z) + kd * ks.z) * (1.0 - ks.x);
    vec3 fresnel = f0 + ((1.0 - ks.x) - f0) * pow(1.0 - clamp(vh, 0.0, 1.0), 5.0);
    float c = clamp(nh, 0.0, 1.0);
    float denom = c * c * (alpha2 - 1.0) + 1.0;
    float d = alpha2 / (LK_PI * denom * denom);
    float cl = clamp(nl, COSINE_EPSILON, 1.0), cv = clamp(nv, COSINE_EPSILON, 1.0);
    float vis = 0.5 / (cl * sqrt(cv * cv * (1.0 - alpha2) + alpha2) + cv * sqrt(cl * cl * (1.0 - alpha2) + alpha2));
    vec3 fd = kd * (1.0 - ks.z) / LK_PI;
    return (fd + fresnel * d * vis) * max(nl, 0.0);
}
void main() {
    vec2 ndc = gl_FragCoord.xy / lk_size * 2.0 - 1.0;
    vec4 far = lk_inverse_mvp * vec4(ndc, 1.0, 1.0);
    vec3 dir = normalize(far.xyz / far.w - lk_eye);
    float footprint = 2.0 / (lk_size.y * lk_proj11) * dot(dir, lk_forward);
    vec3 safe = mix(dir, vec3(1e-12), lessThan(abs(dir), vec3(1e-12)));
    vec3 t0 = (lk_lo - lk_eye) / safe, t1 = (lk_hi - lk_eye) / safe;
    vec3 near3 = min(t0, t1), far3 = max(t0, t1);
    float t = max(max(max(near3.x, near3.y), near3.z), 0.0);
    float t_far = min(min(far3.x, far3.y), far3.z);
    bool hit = false;
    if (t <= t_far) {
        for (int i = 0; i < MAX_STEPS; i++) {
            float d = map(lk_eye + t * dir);
            if (d < HIT_FRACTION * footprint * t) { hit = true; break; }
            t += max(d, 0.0);
            if (t > t_far) break;
        }
    }
    if (!hit) { lk_colour = vec4(0.0); return; }
    vec3 p = lk_eye + t * dir;
    vec3 n = lk_normal(p);
    vec3 kd = clamp(lk_albedo(p), 0.0, 1.0);
    vec3 ks = vec3(0.0, clamp(lk_roughness(p), 0.0, 1.0), clamp(lk_metallic(p), 0.0, 1.0));
    vec3 offset = lk_light_position - p;
    float distance2 = max(dot(offset, offset), 1e-12);
    vec3 l = offset * inversesqrt(distance2);
    vec3 irradiance = lk_intensity / distance2;
    if (lk_horizon != 0 && dot(n, l) <= 0.0) irradiance = vec3(0.0);
    lk_colour = vec4(lk_shade(kd, ks, n, -dir, l) * irradiance, 1.0);
}
"""
"""One sample per fragment: ``sphere_tracing.primary_rays``, ``box_span``, ``sphere_trace``,
``asset.implicit.field_normals`` and ``point_lighting.lit_radiance_python`` (``bsdf.shade``) in GLSL;
no cones (``sphere_tracing.cone_starts``): a fragment cannot share a march with its tile."""


def tracer_constants() -> str:
    """``#define``s of the constants ``sphere_tracing`` and ``bsdf`` use."""
    values = {"MAX_STEPS": str(MAX_STEPS), "HIT_FRACTION": repr(float(HIT_FRACTION)),
              "MIN_ROUGHNESS": repr(float(bsdf.MIN_ROUGHNESS)),
              "COSINE_EPSILON": repr(float(bsdf.COSINE_EPSILON)), "DIELECTRIC_F0": repr(float(bsdf.DIELECTRIC_F0))}
    return "".join(f"#define {name} {value}\n" for name, value in values.items())


class GlslTracer:
    """The sphere-tracing program of one GLSL field (``surface.kind == "glsl"``), compiled once."""

    def __init__(self, surface):
        self.surface = surface
        fragment = (field_header(surface.text) + tracer_constants() + TRACER_UNIFORMS + USER_LINE + surface.text
                    + ours_after_user() + MATERIAL_DEFAULTS + TRACER_MAIN)
        self.program = compile_program(surface.path, FULL_SCREEN, fragment)

    def render(self, camera: Camera, light: PointLight, resolution: int, spp: int = 1) -> torch.Tensor:
        """``[B, H, W, 4]`` as ``sphere_tracing.render_field`` renders it."""
        context = gl_context(self.surface.path)
        size = resolution * spp
        program, surface = self.program, self.surface
        _, radius = surface.bounding_sphere()
        inverse = torch.linalg.inv(camera.mvp.double()).float()
        forward = -camera.mv[:, 2, :3]
        horizon = light.horizon if light.horizon is not None else torch.zeros(light.position.shape[0], dtype=torch.bool)
        target = context.texture((size, size), 4, dtype="f4")
        frame = context.framebuffer(color_attachments=[target])
        vao = context.vertex_array(program, [])
        frame.use()
        images = []
        for b in range(camera.batch_size):
            k = 0 if light.position.shape[0] == 1 else b
            uniforms = {"lk_inverse_mvp": inverse[b].T.contiguous(), "lk_eye": camera.position[b],
                        "lk_forward": forward[b], "lk_proj11": float(camera.proj[b, 1, 1]), "lk_size": (size, size),
                        "lk_light_position": light.position[k], "lk_intensity": light.intensity[k],
                        "lk_horizon": int(bool(horizon[k])), "lk_lo": surface.lo, "lk_hi": surface.hi,
                        "lk_normal_step": NORMAL_STEP * radius}
            for name, value in uniforms.items():
                if name in program:
                    program[name].value = value if isinstance(value, (int, float, tuple)) else tuple(
                        float(x) for x in torch.as_tensor(value).reshape(-1))
            vao.render(vertices=3)
            pixels = np.frombuffer(frame.read(components=4, dtype="f4"), np.float32).reshape(size, size, 4)
            images.append(torch.from_numpy(pixels[::-1].copy()))
        for resource in (vao, frame, target):
            resource.release()
        return box_downsample(torch.stack(images), spp)
