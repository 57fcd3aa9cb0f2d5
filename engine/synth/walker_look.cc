#include "engine/synth/walker_look.h"

#include "engine/synth/random.h"

namespace dypho::synth {

using Eigen::Vector3f;

WalkerLook MakeWalkerLook(int k, uint64_t seed) {
  Rng rng(Hash(seed, 0x100c, static_cast<uint64_t>(k)));
  WalkerLook look;
  look.scale = rng.Uniform(0.92, 1.08);
  const double hue = 0.08 + 0.29 * k + rng.Uniform(-0.05, 0.05);
  const Vector3f shirt = HsvToRgb(hue, rng.Uniform(0.55, 0.85), rng.Uniform(0.55, 0.85));
  const Vector3f pants = HsvToRgb(rng.Uniform(), rng.Uniform(0.2, 0.6), rng.Uniform(0.12, 0.35));
  static const Vector3f kSkins[] = {
      {0.96f, 0.80f, 0.69f}, {0.87f, 0.67f, 0.52f}, {0.67f, 0.47f, 0.33f}, {0.45f, 0.31f, 0.22f}};
  const Vector3f skin = kSkins[rng.UniformInt(0, 3)];
  const Vector3f hair =
      HsvToRgb(rng.Uniform(0.02, 0.12), rng.Uniform(0.3, 0.8), rng.Uniform(0.05, 0.35));
  const int variant = rng.UniformInt(0, 2);
  const bool long_sleeves = rng.Bernoulli(0.5);
  auto style = [&](Material m, const Vector3f& base) {
    PaintStyle s;
    s.material = m;
    s.base = base;
    s.accent = hair;
    s.variant = variant;
    return s;
  };
  for (int p = 0; p < kNumWalkerParts; ++p) {
    PaintStyle s;
    switch (p) {
      case kTorso:
      case kUpperArmLeft:
      case kUpperArmRight:
        s = style(Material::kShirt, shirt);
        break;
      case kLowerArmLeft:
      case kLowerArmRight:
        s = long_sleeves ? style(Material::kShirt, shirt) : style(Material::kSkin, skin);
        break;
      case kNeck:
      case kHead:
        s = style(Material::kSkin, skin);
        break;
      case kFootLeft:
      case kFootRight:
        s = style(Material::kShoe, skin);
        break;
      default:
        s = style(Material::kPants, pants);
        break;
    }
    look.styles[p].fill(s);
  }
  // Head: face at the front (+x), hair on top (+z), skin below.
  for (int f = 0; f < kBoxFaces; ++f) look.styles[kHead][f] = style(Material::kHead, skin);
  look.styles[kHead][0] = style(Material::kFace, skin);
  look.styles[kHead][4] = style(Material::kHair, skin);
  look.styles[kHead][5] = style(Material::kSkin, skin);
  return look;
}


}  // namespace dypho::synth
