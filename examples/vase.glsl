// A glazed vase as a signed distance field in GLSL, for `lookalike simplify examples/vase.glsl`:
// fine periodic relief (forty-eight flutes around the belly, ridged rings around the neck, each a
// few thousandths of its height deep) under glazes that meet at sharp lines: cream below, cobalt
// above a thin red band, and an unglazed terracotta foot.
// lookalike's conventions: map(p) is the signed distance in the asset's units, negative inside,
// never larger than the true distance; albedo(p) is the linear base colour, roughness(p) and
// metallic(p) are optional; the bounds line gives a box that holds the whole surface. +y is up.
// bounds: -0.4 -0.02 -0.4 0.4 1.02 0.4

const float PI = 3.14159265;
const float FLUTES = 48.0;
const float FLUTE_DEPTH = 0.006;
const float RIDGE_PERIOD = 0.024;
const float RIDGE_DEPTH = 0.004;
const float NECK = 0.62;          // where the neck (ridges, cobalt) begins
const float FOOT = 0.06;          // the unglazed foot ends here
// the relief and the lathe's slope tilt the surface: divide by a bound on the gradient's length
const float LIPSCHITZ = 1.9;

// the radius of the vase's outline at height y (a belly, a waist, a flared lip)
float profile(float y) {
    float belly = 0.30 * exp(-pow((y - 0.32) / 0.26, 2.0));
    float lip = 0.07 * smoothstep(0.8, 0.98, y);
    return 0.1 + belly + lip;
}

// the relief pushed into the surface at p (a depth, positive inwards)
float relief(vec3 p) {
    float angle = atan(p.z, p.x);
    float flutes = FLUTE_DEPTH * 0.5 * (1.0 - cos(FLUTES * angle))
                   * smoothstep(0.1, 0.16, p.y) * (1.0 - smoothstep(0.5, 0.56, p.y));
    float ridges = RIDGE_DEPTH * 0.5 * (1.0 - cos(2.0 * PI * p.y / RIDGE_PERIOD))
                   * smoothstep(NECK + 0.02, NECK + 0.05, p.y) * (1.0 - smoothstep(0.86, 0.89, p.y));
    return flutes + ridges;
}

float map(vec3 p) {
    float y = clamp(p.y, 0.0, 1.0);
    float side = length(p.xz) - profile(y) + relief(p);
    float caps = max(-p.y, p.y - 1.0);
    float solid = max(side, caps);
    // hollow from the lip down to a floor above the foot, walls 0.02 thick
    float hollow = max(length(p.xz) - profile(y) + 0.02, 0.12 - p.y);
    return max(solid, -hollow) / LIPSCHITZ;
}

vec3 albedo(vec3 p) {
    vec3 cream = vec3(0.78, 0.70, 0.52);
    vec3 cobalt = vec3(0.03, 0.07, 0.38);
    vec3 red = vec3(0.55, 0.05, 0.03);
    vec3 terracotta = vec3(0.45, 0.2, 0.1);
    if (p.y < FOOT) return terracotta;
    if (p.y < NECK - 0.02) return cream;
    if (p.y < NECK) return red;
    return cobalt;
}

float roughness(vec3 p) {
    return p.y < FOOT ? 0.85 : 0.12;
}
