// Shared definitions of the splat shaders. Every formula mirrors
// kernels/math (projection.h, preprocess.h, blend.h, sh.h) so the Vulkan
// renderer matches the CPU reference rasterizer.

// One projected Gaussian, 4 x vec4 (64 bytes):
//   [0] mean_x, mean_y, half extent x, half extent y of the culling ellipse [px]
//       (extent 0 = not drawn)
//   [1] conic A, B, C, power_min
//   [2] colour r, g, b, opacity
//   [3] camera depth z [m], OIT weight f(z), 0, 0
#define SPLAT_VEC4S 4

// Camera constants (std140 uniform block), filled from
// kernels::math::MakeCameraData on the host.
struct CameraBlock {
  vec4 rot0;       // row 0 of R (xyz), t.x (w)
  vec4 rot1;       // row 1 of R, t.y
  vec4 rot2;       // row 2 of R, t.z
  vec4 center;     // camera centre in world coordinates (xyz)
  vec4 intrinsics; // fx, fy, cx, cy [px]
  vec4 limits;     // tangent limits x_neg, x_pos, y_neg, y_pos
  vec4 planes;     // near, far, low_pass, 0
  ivec4 size;      // width, height, N, sh_coeffs
  ivec4 options;   // sh_degree, order-independent (0/1), 0, 0
};

const float kMaxAlpha = 0.99;
const float kMinAlpha = 1.0 / 255.0;
const float kMaxSigma2 = 9.0;

// kernels/math/types.h ExpNonPositive: 2^n exp(r), Cody-Waite split, degree-7
// Taylor polynomial, x clamped to [-87, 0]. Written out so the per-pixel
// alpha is the same function as on the CPU.
float ExpNonPositive(float x) {
  x = x < -87.0 ? -87.0 : (x > 0.0 ? 0.0 : x);
  precise float n = floor(x * 1.44269504088896341 + 0.5);
  precise float r = (x - n * 0.693145751953125) - n * 1.42860682030941723e-6;
  precise float p = 1.0 / 5040.0;
  p = p * r + 1.0 / 720.0;
  p = p * r + 1.0 / 120.0;
  p = p * r + 1.0 / 24.0;
  p = p * r + 1.0 / 6.0;
  p = p * r + 0.5;
  p = p * r + 1.0;
  p = p * r + 1.0;
  return p * intBitsToFloat((int(n) + 127) << 23);
}

bool IsFinite(float x) { return (floatBitsToUint(x) & 0x7f800000u) != 0x7f800000u; }
