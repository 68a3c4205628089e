// Deferred spectral shading: G-buffer -> linear camera RGB (one invocation per pixel).
//
// Twin of aquaspec/shading.py (shade_gbuffer, float64 NumPy reference): same
// per-pixel branches (hit before the water surface / open water), same model
// functions (common.wgsl <-> aquaspec/model.py). Buffer layouts are
// documented in aquaspec/gpu/deferred.py.
//
// The per-band loop reads the band storage buffers directly: passing arrays
// by value into functions made 32 bands 20x slower on lavapipe.

#include "common.wgsl"

{{ camera_struct }}

struct Band {
    c: f32,        // extinction a + b, 1/m
    b: f32,        // scattering, 1/m
    kd: f32,       // diffuse downwelling attenuation, 1/m
    e0: f32,       // downwelling irradiance below the surface, W m^-2 nm^-1
    w_r: f32,      // camera response weights (response x band width)
    w_g: f32,
    w_b: f32,
    t: f32,        // normalised band-centre wavelength (lambda - 550) / 100
};

// Material index meaning "use this pixel's sigmoid coefficients" (gbuffer.PER_PIXEL).
const PER_PIXEL: u32 = 0xffffffffu;

@group(0) @binding(0) var<uniform> cam: {{ camera_struct_name }};
@group(0) @binding(1) var<storage, read> gb_distance: array<f32>;
@group(0) @binding(2) var<storage, read> gb_surface: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read> gb_sigmoid: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> bands: array<Band>;
@group(0) @binding(5) var<storage, read> material_bands: array<f32>;
@group(0) @binding(6) var<storage, read_write> rgb_out: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> radiance_out: array<f32>;
@group(0) @binding(8) var<storage, read_write> status: array<atomic<u32>>;

// Camera.ray_directions: through the pixel centre (j + 0.5, i + 0.5).
fn ray_direction(j: u32, i: u32) -> vec3<f32> {
    let x = (f32(j) + 0.5 - cam.cx) / cam.fx;
    let y = (f32(i) + 0.5 - cam.cy) / cam.fy;
    return normalize(cam.right * x - cam.up * y + cam.forward);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= cam.width || gid.y >= cam.height) {
        return;
    }
    let p = gid.y * cam.width + gid.x;
    let v = ray_direction(gid.x, gid.y);
    let v_y = v.y;
    let depth_o = -cam.position.y;

    let s_gb = gb_distance[p];
    let surf = gb_surface[p];
    // A hit counts only if the ray reaches it before the water surface.
    var hit = s_gb >= 0.0;
    if (hit && v_y > 0.0) {
        hit = s_gb <= depth_o / v_y;
    }
    let rl = ray_length(s_gb, hit, depth_o, v_y);
    let s = rl.x;
    let s_finite = rl.y > 0.0;

    var surface_depth = 0.0;
    var n_y = 0.0;
    var material = 0u;
    var sig = vec3<f32>(0.0);
    var use_sigmoid = false;
    if (hit) {
        surface_depth = -(cam.position.y + s * v_y);
        n_y = bitcast<f32>(surf.y);
        material = surf.w;
        use_sigmoid = material == PER_PIXEL;
        if (use_sigmoid) {
            sig = gb_sigmoid[p].xyz;
        } else if (material >= cam.n_materials) {
            // Reported to the host, which raises; the pixel gets rho = 0.
            atomicAdd(&status[0], 1u);
        }
    }
    let sees_surface = !hit && s_finite && v_y > 0.0;

    var rgb = vec3<f32>(0.0);
    for (var i = 0u; i < cam.n_bands; i = i + 1u) {
        let c = bands[i].c;
        let kd = bands[i].kd;
        let e0 = bands[i].e0;
        let l_ms = l_ms_seeds(bands[i].b, c, kd, e0, depth_o, v_y, s, s_finite);
        var l_surf = 0.0;
        if (hit) {
            var rho = 0.0;
            if (use_sigmoid) {
                rho = sigmoid_reflectance(sig, bands[i].t);
            } else if (material < cam.n_materials) {
                rho = material_bands[material * cam.n_bands + i];
            }
            l_surf = lambertian_radiance(
                rho, ambient_irradiance(e0, kd, surface_depth, n_y, cam.ambient_model));
        } else if (sees_surface) {
            l_surf = surface_from_below(e0, v_y, cam.snell_cos, cam.window_factor);
        }
        let tr = transmittance(c, s, s_finite);
        var l = l_ms;
        if (tr > 0.0) {
            l = tr * l_surf + l_ms;
        }
        rgb = rgb + l * vec3<f32>(bands[i].w_r, bands[i].w_g, bands[i].w_b);
        if (cam.write_radiance != 0u) {
            radiance_out[p * cam.n_bands + i] = l;
        }
    }
    rgb_out[p] = vec4<f32>(rgb, 1.0);
}
