// The scene's shadow along camera rays that end on a surface, over directions
// around each ray: the GPU twin of aquaspec.transport.lightfield.shadow.ShadowContext.hit_rays (float64
// NumPy), run by aquaspec.gpu.passes.shadow_hit.HitRayPass. Conventions: metres,
// y up, water surface y = 0, depth d = -p.y.
//
// One workgroup per receiver (a hit pixel's ray, direction v, length s).
// Its invocations share out the direction cells j (around v, in the frame
// v, e1, e2) and walk the nodes u back from the hit for each: the direction
// w meets the hit's tangent plane at q; q blocks where the G-buffer sees a
// surface at q's distance (2 % or 2 cm). A blocked sample adds, per band,
// (L_bg(d_q, w_y) - L_s) [in the forward cone L_bg(d_q, w_y) - L_bg(d_q, v'_y)]
// p_j exp(-k (s - u + r)) dw_j wu to a private sum, which the workgroup then
// adds up. The host multiplies by b. q is taken relative to the camera (dq),
// as NumPy does.
//
// Bands are four to a vec4 (the last padded with zeros): one vec4 load per
// texel and four bands took the 1280x720 test (575 rays, 8 bands) from 0.76
// to 0.25 s on lavapipe; one band loop for both cases of the cone (the
// texel lookup inside a uniform-per-cell branch) to 0.21 s.

#include "common.wgsl"
#include "lftables.wgsl"

{{ params_struct }}

const N4: u32 = {{ n_vec4 }}u;          // vec4 of bands
const WORKGROUP: u32 = {{ workgroup }}u;
const CHUNK: u32 = {{ chunk }}u;        // vec4 of bands summed at a time

struct Cell {
    dir: vec4<f32>,     // cos theta, sin theta cos phi, sin theta sin phi, dw
    in_cone: u32,       // cos theta > cos of the tables' forward cone
    pad0: u32,
    pad1: u32,
    pad2: u32,
};

struct Receiver {
    v: vec4<f32>,       // ray direction, s (hit distance)
    e1: vec4<f32>,      // frame, clamp(-v . n, 0, 1)
    e2: vec4<f32>,      // frame, 0
    nrm: vec4<f32>,     // hit normal, 0
};

@group(0) @binding(0) var<uniform> par: {{ params_name }};
// Cells 0 .. n_cells - 1, then the nodes along the ray: cell n_cells + i
// holds (x_i^2, 2 x_i w_i, 0, 0) (Gauss-Legendre on [0, 1]).
@group(0) @binding(1) var<storage, read> cells: array<Cell>;
// The band phase functions per cell, p[j * N4 + g], then k[g].
@group(0) @binding(2) var<storage, read> band_data: array<vec4<f32>>;
// L_bg(d, w_y) on the tables' axes, [depth][cos][g] (ctx.lrad_e0).
@group(0) @binding(3) var<storage, read> lrad: array<vec4<f32>>;
// The G-buffer: hit distance per pixel (negative: no hit), surface radiance [pixel][g].
@group(0) @binding(4) var<storage, read> gb_distance: array<f32>;
@group(0) @binding(5) var<storage, read> gb_radiance: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> receivers: array<Receiver>;
@group(0) @binding(7) var<storage, read_write> result: array<vec4<f32>>;

var<workgroup> partial: array<vec4<f32>, {{ shared_len }}>;

// Lower texel (flat index of its first vec4) and weights of a bilinear lookup
// (lightfield.bilinear, band_last): depth d, direction cosine c.
struct Texel {
    base: u32,
    fx: f32,
    fy: f32,
};

fn texel(d: f32, c: f32) -> Texel {
    let x = table_depth_coord(vec4<f32>(d), par.max_depth, par.n_depth).x;
    let y = table_cos_coord(vec4<f32>(c), par.n_mu).x;
    let i = min(u32(floor(x)), par.n_depth - 2u);
    let j = min(u32(floor(y)), par.n_mu - 2u);
    return Texel((i * par.n_mu + j) * N4, x - f32(i), y - f32(j));
}

fn lookup(t: Texel, g: u32) -> vec4<f32> {
    let row = par.n_mu * N4;           // (one depth step)
    let a = t.base + g;
    return (1.0 - t.fx) * ((1.0 - t.fy) * lrad[a] + t.fy * lrad[a + N4])
        + t.fx * ((1.0 - t.fy) * lrad[a + row] + t.fy * lrad[a + row + N4]);
}

@compute @workgroup_size({{ workgroup }})
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let rec = wg.y * nwg.x + wg.x;
    if (rec >= par.n_receivers) {       // (the whole workgroup)
        return;
    }
    let rv = receivers[rec];
    let v = rv.v.xyz;
    let s = rv.v.w;
    let cos_n = rv.e1.w;
    let k_at = par.n_cells * N4;
    var acc: array<vec4<f32>, N4>;
    for (var g = 0u; g < N4; g++) {
        acc[g] = vec4<f32>(0.0);
    }
    for (var jc = lid; jc < par.n_cells; jc += WORKGROUP) {
        let cell = cells[jc];
        let w = cell.dir.x * v + cell.dir.y * rv.e1.xyz + cell.dir.z * rv.e2.xyz;
        let towards = -dot(w, rv.nrm.xyz);
        if (towards <= 1e-6) {          // (never meets the plane: never blocks)
            continue;
        }
        let cone = cell.in_cone != 0u;
        let p_at = jc * N4;
        for (var iu = 0u; iu < par.n_nodes; iu++) {
            // u: distance back from the hit; q = x + r w on the hit's plane.
            let node = cells[par.n_cells + iu].dir;
            let u = s * node.x;
            let r = u * cos_n / towards;
            let dq = (s - u) * v + r * w;
            let z = dot(dq, par.forward);
            if (z <= 1e-9) {
                continue;
            }
            let fc = floor(par.cx + par.fx * dot(dq, par.right) / z);
            let fr = floor(par.cy - par.fy * dot(dq, par.up) / z);
            if (fc < 0.0 || fr < 0.0 || fc >= f32(par.width) || fr >= f32(par.height)) {
                continue;
            }
            let px = u32(fr) * par.width + u32(fc);
            let seen = gb_distance[px];
            let dist_q = length(dq);
            if (seen < 0.0 || abs(seen - dist_q) >= max(0.02 * dist_q, 0.02)) {
                continue;
            }
            let d_q = max(-(par.position.y + dq.y), 0.0);
            let along = texel(d_q, w.y);
            // (In the forward cone, less what the cone took: the blocker's
            // radiance along its own camera ray; L_s cancels.)
            let own = texel(d_q, dq.y / dist_q);
            let weight = cell.dir.w * s * node.y;
            let path = s - u + r;
            let ls_at = px * N4;
            for (var g = 0u; g < N4; g++) {
                var sub = gb_radiance[ls_at + g];
                if (cone) {
                    sub = lookup(own, g);
                }
                acc[g] += (lookup(along, g) - sub) * band_data[p_at + g]
                    * exp(-band_data[k_at + g] * path) * weight;
            }
        }
    }
    // The workgroup's sum, CHUNK vec4 at a time (16 KB of workgroup memory).
    for (var c0 = 0u; c0 < N4; c0 += CHUNK) {
        for (var i = 0u; i < CHUNK; i++) {
            if (c0 + i < N4) {
                partial[lid * CHUNK + i] = acc[c0 + i];
            }
        }
        workgroupBarrier();
        if (lid < CHUNK && c0 + lid < N4) {
            var total = vec4<f32>(0.0);
            for (var k = 0u; k < WORKGROUP; k++) {
                total += partial[k * CHUNK + lid];
            }
            result[rec * N4 + c0 + lid] = total;
        }
        workgroupBarrier();
    }
}
