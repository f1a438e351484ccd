// A brass gear as a signed distance field in GLSL, for `lookalike simplify examples/gear.glsl`.
// lookalike's conventions: map(p) is the signed distance in the asset's units, negative inside,
// never larger than the true distance; albedo(p) is the linear base colour, roughness(p) and
// metallic(p) are optional; the bounds line gives a box that holds the whole surface. +y is up.
// bounds: -0.62 -0.16 -0.62 0.62 0.16 0.62

const float PI = 3.14159265;

float cylinder(vec3 p, float radius, float half_height) {
    vec2 d = vec2(length(p.xz) - radius, abs(p.y) - half_height);
    return min(max(d.x, d.y), 0.0) + length(max(d, 0.0));
}

float teeth(vec3 p) {
    // sixteen teeth: fold the angle into one sector and take a box in it
    float sector = 2.0 * PI / 16.0;
    float angle = atan(p.z, p.x);
    float a = mod(angle + 0.5 * sector, sector) - 0.5 * sector;
    vec2 q = length(p.xz) * vec2(cos(a), sin(a));
    vec3 b = vec3(q.x - 0.53, p.y, q.y);
    vec3 d = abs(b) - vec3(0.07, 0.07, 0.045);
    return (min(max(d.x, max(d.y, d.z)), 0.0) + length(max(d, 0.0))) * 0.8;
}

float map(vec3 p) {
    float body = cylinder(p, 0.48, 0.07) - 0.01;
    float gear = min(body, teeth(p));
    float hub = cylinder(p, 0.14, 0.12) - 0.01;
    gear = min(gear, hub);
    float hole = cylinder(p, 0.06, 0.2);
    // six round windows in the web
    float sector = 2.0 * PI / 6.0;
    float a = mod(atan(p.z, p.x) + 0.5 * sector, sector) - 0.5 * sector;
    vec2 q = length(p.xz) * vec2(cos(a), sin(a));
    float window = length(vec2(q.x - 0.30, q.y)) - 0.09;
    window = max(window, abs(p.y) - 0.2);
    // a groove around the rim, on both faces
    float groove = length(vec2(length(p.xz) - 0.42, abs(p.y) - 0.08)) - 0.012;
    return max(gear, -min(min(hole, window), groove));
}

vec3 albedo(vec3 p) {
    float r = length(p.xz);
    vec3 brass = vec3(0.78, 0.55, 0.22);
    vec3 steel = vec3(0.55, 0.56, 0.58);
    return r < 0.16 ? steel : brass * (0.9 + 0.1 * sin(60.0 * r));
}

float roughness(vec3 p) {
    return length(p.xz) < 0.16 ? 0.25 : 0.4;
}

float metallic(vec3 p) {
    return 1.0;
}
