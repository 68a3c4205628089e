// The scene's shadow along open-water camera rays, summed over the source
// blocks: the GPU twin of aquaspec.transport.lightfield.shadow.ShadowContext.open_ray (float64
// NumPy), run by aquaspec.gpu.passes.shadow_open.OpenRayPass. Conventions: metres,
// y up, water surface y = 0, depth d = -p.y.
//
// One invocation per (ray, node): the point x = o + t v, t = node * t_step.
// Each source block (mean point y, normal n, area A) facing x adds, per band,
//   solid (p0 + mix (p1 - p0)) (L_src(look_y) - L_s - [mu > cos theta_c] dL_cone) exp(-k r)
// with w = y - x, r = |w|, u = w / r, mu = u . v, th = angle(u, v),
// solid = max(-n . u, 0) min(A / r^2, disc), cap = acos(1 - solid / 2 pi),
// (p0, p1, shift) the cap-averaged phase table at (th, cap) and look_y the
// up component of u turned towards v by min(shift, th). The sum is
// multiplied by b exp(-k t) once at the end.
//
// Bands are four to a vec4 (the last padded with zeros) in every per-band
// buffer: on the built-in scene at 1280x720 (413 rays, 988 sources, 8 bands)
// a loop over single bands in a private array<f32, 8> took 0.9 s on
// lavapipe, over vec4 0.6 s (the geometry alone 0.4 s).

{{ params_struct }}

const N4: u32 = {{ n_vec4 }}u;          // vec4 of bands
const WORKGROUP: u32 = {{ workgroup }}u;
const PI: f32 = 3.14159265358979;
const TWO_PI: f32 = 6.28318530717959;

@group(0) @binding(0) var<uniform> par: {{ params_name }};
// Ray directions (xyz, 0).
@group(0) @binding(1) var<storage, read> rays: array<vec4<f32>>;
// Per source two vec4: (mean point, area), (unit normal, 0).
@group(0) @binding(2) var<storage, read> src_geom: array<vec4<f32>>;
// Per source its radiance row less its own radiance, [source][cos][g]
// (ctx.src_rows - ctx.l_s), then ctx.in_cone_dl [source][g] from
// cone_offset (g: vec4 of bands).
@group(0) @binding(3) var<storage, read> src_bands: array<vec4<f32>>;
// The cap-averaged phase table [theta][alpha] (p0, p1, shift, 0) (ctx.disc_all).
@group(0) @binding(4) var<storage, read> disc: array<vec4<f32>>;
// Its nodes: ctx.disc_theta, then ctx.disc_alpha.
@group(0) @binding(5) var<storage, read> disc_nodes: array<f32>;
// k [g], then mix [g], then b [g] (the band phase function is p0 + mix (p1 - p0)).
@group(0) @binding(6) var<storage, read> bands: array<vec4<f32>>;
// The integrand [ray][node][g].
@group(0) @binding(7) var<storage, read_write> result: array<vec4<f32>>;

// arcsin of 0 <= z <= 1 (Cephes asinf polynomial on |z| <= 0.5; not WGSL's
// asin / acos, which lavapipe gets wrong by up to 1.6e-4 rad).
fn asin_small(z: f32) -> f32 {
    let q = z * z;
    return z + z * q * ((((4.2163199048e-2 * q + 2.4181311049e-2) * q + 4.5470025998e-2) * q
        + 7.4953002686e-2) * q + 1.6666752422e-1);
}

fn asin_pos(z: f32) -> f32 {
    if (z <= 0.5) {
        return asin_small(z);
    }
    return 0.5 * PI - 2.0 * asin_small(sqrt(0.5 - 0.5 * min(z, 1.0)));
}

fn acos_acc(c: f32) -> f32 {
    let a = asin_pos(min(abs(c), 1.0));
    return select(0.5 * PI - a, 0.5 * PI + a, c < 0.0);
}

// np.interp(x, nodes, arange(count)) on geometric nodes nodes[first ..
// first + count) (ratio = log(last / first node)), as (cell, fraction): the
// cell from the log, then the fraction from the node values; clamped to
// the axis' ends.
struct Cell {
    i: u32,
    f: f32,
};

fn geometric_cell(x: f32, first: u32, count: u32, ratio: f32) -> Cell {
    let n0 = disc_nodes[first];
    let g = log(max(x, n0) / n0) / ratio * f32(count - 1u);
    var i = u32(clamp(floor(g), 0.0, f32(count - 2u)));
    if (i > 0u && x < disc_nodes[first + i]) {
        i = i - 1u;
    } else if (i < count - 2u && x > disc_nodes[first + i + 1u]) {
        i = i + 1u;
    }
    let lo = disc_nodes[first + i];
    let hi = disc_nodes[first + i + 1u];
    return Cell(i, clamp((x - lo) / (hi - lo), 0.0, 1.0));
}

@compute @workgroup_size(WORKGROUP)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let flat = gid.x + gid.y * par.row_invocations;
    if (flat >= par.n_rays * par.n_nodes) {
        return;
    }
    let ray = flat / par.n_nodes;
    let t = f32(flat % par.n_nodes) * par.t_step;
    let v = rays[ray].xyz;
    let x = par.origin.xyz + t * v;
    let n_theta = par.n_theta;
    let n_alpha = par.n_alpha;
    let n_mu = par.n_mu;
    var acc: array<vec4<f32>, N4>;
    for (var i = 0u; i < N4; i++) {
        acc[i] = vec4<f32>(0.0);
    }
    for (var m = 0u; m < par.n_sources; m++) {
        let g0 = src_geom[2u * m];
        let w = g0.xyz - x;
        let r = max(length(w), 1e-9);
        let u = w / r;
        let facing = max(-dot(src_geom[2u * m + 1u].xyz, u), 0.0);
        if (facing <= 0.0) {
            continue;
        }
        // The on-axis disc of area A: 2 pi (1 - r / s) = 2 A / (s (s + r)).
        let area = g0.w;
        let s = sqrt(r * r + area / PI);
        let solid = facing * min(area / (r * r), 2.0 * area / (s * (s + r)));
        let cuv = cross(u, v);
        let sin_th = length(cuv);
        let mu = dot(u, v);
        let th = atan2(sin_th, mu);
        // acos(1 - solid / 2 pi) = 2 asin(sqrt(solid / 4 pi)).
        let cap = 2.0 * asin_pos(sqrt(solid / (2.0 * TWO_PI)));
        // Theta: node 0 is 0, then geometric from node 1.
        var ct: Cell;
        let t1 = disc_nodes[1];
        if (th < t1) {
            ct = Cell(0u, th / t1);
        } else {
            let c = geometric_cell(th, 1u, n_theta - 1u, par.log_theta);
            ct = Cell(c.i + 1u, c.f);
        }
        let ca = geometric_cell(cap, n_theta, n_alpha, par.log_alpha);
        let k00 = ct.i * n_alpha + ca.i;
        let ph = (1.0 - ct.f) * ((1.0 - ca.f) * disc[k00] + ca.f * disc[k00 + 1u])
            + ct.f * ((1.0 - ca.f) * disc[k00 + n_alpha] + ca.f * disc[k00 + n_alpha + 1u]);
        // The radiance where the cap's phase function puts its weight: u
        // turned towards v (perp = v - mu u = (u x v) x u, normalised) by
        // min(shift, th).
        let turn = min(ph.z, th);
        let perp_y = cross(cuv, u).y / max(sin_th, 1e-12);
        let look_y = cos(turn) * u.y + sin(turn) * perp_y;
        let yc = (1.0 - acos_acc(clamp(look_y, -1.0, 1.0)) / PI) * f32(n_mu - 1u);
        let j = min(u32(max(floor(yc), 0.0)), n_mu - 2u);
        let fy = yc - f32(j);
        let row = (m * n_mu + j) * N4;
        let cone = select(0.0, 1.0, mu > par.cone_cos);
        let cone_row = par.cone_offset + m * N4;
        let w0 = solid * ph.x;
        let w1 = solid * (ph.y - ph.x);
        for (var i = 0u; i < N4; i++) {
            let dl = (1.0 - fy) * src_bands[row + i] + fy * src_bands[row + N4 + i]
                - cone * src_bands[cone_row + i];
            acc[i] += (w0 + bands[N4 + i] * w1) * dl * exp(-bands[i] * r);
        }
    }
    let out = flat * N4;
    for (var i = 0u; i < N4; i++) {
        result[out + i] = acc[i] * bands[2u * N4 + i] * exp(-bands[i] * t);
    }
}
