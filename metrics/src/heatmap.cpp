#include "scanbench/metrics/heatmap.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <system_error>
#include <vector>

#include "scanbench/core/errors.h"
#include "scanbench/core/files.h"

namespace scanbench::metrics {

namespace {

namespace IBA = OIIO::ImageBufAlgo;

constexpr int kTitleRows = 40;

// Viridis (S. van der Walt, N. Smith, E. Firing; matplotlib's 256 colours, released CC0):
// perceptually uniform, readable in grey and by colour-blind readers.
constexpr float kViridis[256][3] = {
    {0.267004f, 0.004874f, 0.329415f}, {0.268510f, 0.009605f, 0.335427f},
    {0.269944f, 0.014625f, 0.341379f}, {0.271305f, 0.019942f, 0.347269f},
    {0.272594f, 0.025563f, 0.353093f}, {0.273809f, 0.031497f, 0.358853f},
    {0.274952f, 0.037752f, 0.364543f}, {0.276022f, 0.044167f, 0.370164f},
    {0.277018f, 0.050344f, 0.375715f}, {0.277941f, 0.056324f, 0.381191f},
    {0.278791f, 0.062145f, 0.386592f}, {0.279566f, 0.067836f, 0.391917f},
    {0.280267f, 0.073417f, 0.397163f}, {0.280894f, 0.078907f, 0.402329f},
    {0.281446f, 0.084320f, 0.407414f}, {0.281924f, 0.089666f, 0.412415f},
    {0.282327f, 0.094955f, 0.417331f}, {0.282656f, 0.100196f, 0.422160f},
    {0.282910f, 0.105393f, 0.426902f}, {0.283091f, 0.110553f, 0.431554f},
    {0.283197f, 0.115680f, 0.436115f}, {0.283229f, 0.120777f, 0.440584f},
    {0.283187f, 0.125848f, 0.444960f}, {0.283072f, 0.130895f, 0.449241f},
    {0.282884f, 0.135920f, 0.453427f}, {0.282623f, 0.140926f, 0.457517f},
    {0.282290f, 0.145912f, 0.461510f}, {0.281887f, 0.150881f, 0.465405f},
    {0.281412f, 0.155834f, 0.469201f}, {0.280868f, 0.160771f, 0.472899f},
    {0.280255f, 0.165693f, 0.476498f}, {0.279574f, 0.170599f, 0.479997f},
    {0.278826f, 0.175490f, 0.483397f}, {0.278012f, 0.180367f, 0.486697f},
    {0.277134f, 0.185228f, 0.489898f}, {0.276194f, 0.190074f, 0.493001f},
    {0.275191f, 0.194905f, 0.496005f}, {0.274128f, 0.199721f, 0.498911f},
    {0.273006f, 0.204520f, 0.501721f}, {0.271828f, 0.209303f, 0.504434f},
    {0.270595f, 0.214069f, 0.507052f}, {0.269308f, 0.218818f, 0.509577f},
    {0.267968f, 0.223549f, 0.512008f}, {0.266580f, 0.228262f, 0.514349f},
    {0.265145f, 0.232956f, 0.516599f}, {0.263663f, 0.237631f, 0.518762f},
    {0.262138f, 0.242286f, 0.520837f}, {0.260571f, 0.246922f, 0.522828f},
    {0.258965f, 0.251537f, 0.524736f}, {0.257322f, 0.256130f, 0.526563f},
    {0.255645f, 0.260703f, 0.528312f}, {0.253935f, 0.265254f, 0.529983f},
    {0.252194f, 0.269783f, 0.531579f}, {0.250425f, 0.274290f, 0.533103f},
    {0.248629f, 0.278775f, 0.534556f}, {0.246811f, 0.283237f, 0.535941f},
    {0.244972f, 0.287675f, 0.537260f}, {0.243113f, 0.292092f, 0.538516f},
    {0.241237f, 0.296485f, 0.539709f}, {0.239346f, 0.300855f, 0.540844f},
    {0.237441f, 0.305202f, 0.541921f}, {0.235526f, 0.309527f, 0.542944f},
    {0.233603f, 0.313828f, 0.543914f}, {0.231674f, 0.318106f, 0.544834f},
    {0.229739f, 0.322361f, 0.545706f}, {0.227802f, 0.326594f, 0.546532f},
    {0.225863f, 0.330805f, 0.547314f}, {0.223925f, 0.334994f, 0.548053f},
    {0.221989f, 0.339161f, 0.548752f}, {0.220057f, 0.343307f, 0.549413f},
    {0.218130f, 0.347432f, 0.550038f}, {0.216210f, 0.351535f, 0.550627f},
    {0.214298f, 0.355619f, 0.551184f}, {0.212395f, 0.359683f, 0.551710f},
    {0.210503f, 0.363727f, 0.552206f}, {0.208623f, 0.367752f, 0.552675f},
    {0.206756f, 0.371758f, 0.553117f}, {0.204903f, 0.375746f, 0.553533f},
    {0.203063f, 0.379716f, 0.553925f}, {0.201239f, 0.383670f, 0.554294f},
    {0.199430f, 0.387607f, 0.554642f}, {0.197636f, 0.391528f, 0.554969f},
    {0.195860f, 0.395433f, 0.555276f}, {0.194100f, 0.399323f, 0.555565f},
    {0.192357f, 0.403199f, 0.555836f}, {0.190631f, 0.407061f, 0.556089f},
    {0.188923f, 0.410910f, 0.556326f}, {0.187231f, 0.414746f, 0.556547f},
    {0.185556f, 0.418570f, 0.556753f}, {0.183898f, 0.422383f, 0.556944f},
    {0.182256f, 0.426184f, 0.557120f}, {0.180629f, 0.429975f, 0.557282f},
    {0.179019f, 0.433756f, 0.557430f}, {0.177423f, 0.437527f, 0.557565f},
    {0.175841f, 0.441290f, 0.557685f}, {0.174274f, 0.445044f, 0.557792f},
    {0.172719f, 0.448791f, 0.557885f}, {0.171176f, 0.452530f, 0.557965f},
    {0.169646f, 0.456262f, 0.558030f}, {0.168126f, 0.459988f, 0.558082f},
    {0.166617f, 0.463708f, 0.558119f}, {0.165117f, 0.467423f, 0.558141f},
    {0.163625f, 0.471133f, 0.558148f}, {0.162142f, 0.474838f, 0.558140f},
    {0.160665f, 0.478540f, 0.558115f}, {0.159194f, 0.482237f, 0.558073f},
    {0.157729f, 0.485932f, 0.558013f}, {0.156270f, 0.489624f, 0.557936f},
    {0.154815f, 0.493313f, 0.557840f}, {0.153364f, 0.497000f, 0.557724f},
    {0.151918f, 0.500685f, 0.557587f}, {0.150476f, 0.504369f, 0.557430f},
    {0.149039f, 0.508051f, 0.557250f}, {0.147607f, 0.511733f, 0.557049f},
    {0.146180f, 0.515413f, 0.556823f}, {0.144759f, 0.519093f, 0.556572f},
    {0.143343f, 0.522773f, 0.556295f}, {0.141935f, 0.526453f, 0.555991f},
    {0.140536f, 0.530132f, 0.555659f}, {0.139147f, 0.533812f, 0.555298f},
    {0.137770f, 0.537492f, 0.554906f}, {0.136408f, 0.541173f, 0.554483f},
    {0.135066f, 0.544853f, 0.554029f}, {0.133743f, 0.548535f, 0.553541f},
    {0.132444f, 0.552216f, 0.553018f}, {0.131172f, 0.555899f, 0.552459f},
    {0.129933f, 0.559582f, 0.551864f}, {0.128729f, 0.563265f, 0.551229f},
    {0.127568f, 0.566949f, 0.550556f}, {0.126453f, 0.570633f, 0.549841f},
    {0.125394f, 0.574318f, 0.549086f}, {0.124395f, 0.578002f, 0.548287f},
    {0.123463f, 0.581687f, 0.547445f}, {0.122606f, 0.585371f, 0.546557f},
    {0.121831f, 0.589055f, 0.545623f}, {0.121148f, 0.592739f, 0.544641f},
    {0.120565f, 0.596422f, 0.543611f}, {0.120092f, 0.600104f, 0.542530f},
    {0.119738f, 0.603785f, 0.541400f}, {0.119512f, 0.607464f, 0.540218f},
    {0.119423f, 0.611141f, 0.538982f}, {0.119483f, 0.614817f, 0.537692f},
    {0.119699f, 0.618490f, 0.536347f}, {0.120081f, 0.622161f, 0.534946f},
    {0.120638f, 0.625828f, 0.533488f}, {0.121380f, 0.629492f, 0.531973f},
    {0.122312f, 0.633153f, 0.530398f}, {0.123444f, 0.636809f, 0.528763f},
    {0.124780f, 0.640461f, 0.527068f}, {0.126326f, 0.644107f, 0.525311f},
    {0.128087f, 0.647749f, 0.523491f}, {0.130067f, 0.651384f, 0.521608f},
    {0.132268f, 0.655014f, 0.519661f}, {0.134692f, 0.658636f, 0.517649f},
    {0.137339f, 0.662252f, 0.515571f}, {0.140210f, 0.665859f, 0.513427f},
    {0.143303f, 0.669459f, 0.511215f}, {0.146616f, 0.673050f, 0.508936f},
    {0.150148f, 0.676631f, 0.506589f}, {0.153894f, 0.680203f, 0.504172f},
    {0.157851f, 0.683765f, 0.501686f}, {0.162016f, 0.687316f, 0.499129f},
    {0.166383f, 0.690856f, 0.496502f}, {0.170948f, 0.694384f, 0.493803f},
    {0.175707f, 0.697900f, 0.491033f}, {0.180653f, 0.701402f, 0.488189f},
    {0.185783f, 0.704891f, 0.485273f}, {0.191090f, 0.708366f, 0.482284f},
    {0.196571f, 0.711827f, 0.479221f}, {0.202219f, 0.715272f, 0.476084f},
    {0.208030f, 0.718701f, 0.472873f}, {0.214000f, 0.722114f, 0.469588f},
    {0.220124f, 0.725509f, 0.466226f}, {0.226397f, 0.728888f, 0.462789f},
    {0.232815f, 0.732247f, 0.459277f}, {0.239374f, 0.735588f, 0.455688f},
    {0.246070f, 0.738910f, 0.452024f}, {0.252899f, 0.742211f, 0.448284f},
    {0.259857f, 0.745492f, 0.444467f}, {0.266941f, 0.748751f, 0.440573f},
    {0.274149f, 0.751988f, 0.436601f}, {0.281477f, 0.755203f, 0.432552f},
    {0.288921f, 0.758394f, 0.428426f}, {0.296479f, 0.761561f, 0.424223f},
    {0.304148f, 0.764704f, 0.419943f}, {0.311925f, 0.767822f, 0.415586f},
    {0.319809f, 0.770914f, 0.411152f}, {0.327796f, 0.773980f, 0.406640f},
    {0.335885f, 0.777018f, 0.402049f}, {0.344074f, 0.780029f, 0.397381f},
    {0.352360f, 0.783011f, 0.392636f}, {0.360741f, 0.785964f, 0.387814f},
    {0.369214f, 0.788888f, 0.382914f}, {0.377779f, 0.791781f, 0.377939f},
    {0.386433f, 0.794644f, 0.372886f}, {0.395174f, 0.797475f, 0.367757f},
    {0.404001f, 0.800275f, 0.362552f}, {0.412913f, 0.803041f, 0.357269f},
    {0.421908f, 0.805774f, 0.351910f}, {0.430983f, 0.808473f, 0.346476f},
    {0.440137f, 0.811138f, 0.340967f}, {0.449368f, 0.813768f, 0.335384f},
    {0.458674f, 0.816363f, 0.329727f}, {0.468053f, 0.818921f, 0.323998f},
    {0.477504f, 0.821444f, 0.318195f}, {0.487026f, 0.823929f, 0.312321f},
    {0.496615f, 0.826376f, 0.306377f}, {0.506271f, 0.828786f, 0.300362f},
    {0.515992f, 0.831158f, 0.294279f}, {0.525776f, 0.833491f, 0.288127f},
    {0.535621f, 0.835785f, 0.281908f}, {0.545524f, 0.838039f, 0.275626f},
    {0.555484f, 0.840254f, 0.269281f}, {0.565498f, 0.842430f, 0.262877f},
    {0.575563f, 0.844566f, 0.256415f}, {0.585678f, 0.846661f, 0.249897f},
    {0.595839f, 0.848717f, 0.243329f}, {0.606045f, 0.850733f, 0.236712f},
    {0.616293f, 0.852709f, 0.230052f}, {0.626579f, 0.854645f, 0.223353f},
    {0.636902f, 0.856542f, 0.216620f}, {0.647257f, 0.858400f, 0.209861f},
    {0.657642f, 0.860219f, 0.203082f}, {0.668054f, 0.861999f, 0.196293f},
    {0.678489f, 0.863742f, 0.189503f}, {0.688944f, 0.865448f, 0.182725f},
    {0.699415f, 0.867117f, 0.175971f}, {0.709898f, 0.868751f, 0.169257f},
    {0.720391f, 0.870350f, 0.162603f}, {0.730889f, 0.871916f, 0.156029f},
    {0.741388f, 0.873449f, 0.149561f}, {0.751884f, 0.874951f, 0.143228f},
    {0.762373f, 0.876424f, 0.137064f}, {0.772852f, 0.877868f, 0.131109f},
    {0.783315f, 0.879285f, 0.125405f}, {0.793760f, 0.880678f, 0.120005f},
    {0.804182f, 0.882046f, 0.114965f}, {0.814576f, 0.883393f, 0.110347f},
    {0.824940f, 0.884720f, 0.106217f}, {0.835270f, 0.886029f, 0.102646f},
    {0.845561f, 0.887322f, 0.099702f}, {0.855810f, 0.888601f, 0.097452f},
    {0.866013f, 0.889868f, 0.095953f}, {0.876168f, 0.891125f, 0.095250f},
    {0.886271f, 0.892374f, 0.095374f}, {0.896320f, 0.893616f, 0.096335f},
    {0.906311f, 0.894855f, 0.098125f}, {0.916242f, 0.896091f, 0.100717f},
    {0.926106f, 0.897330f, 0.104071f}, {0.935904f, 0.898570f, 0.108131f},
    {0.945636f, 0.899815f, 0.112838f}, {0.955300f, 0.901065f, 0.118128f},
    {0.964894f, 0.902323f, 0.123941f}, {0.974417f, 0.903590f, 0.130215f},
    {0.983868f, 0.904867f, 0.136897f}, {0.993248f, 0.906157f, 0.143936f},
};
constexpr int kBarColumns = 110;

std::string font() {
  const char* path = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
  return std::filesystem::exists(path) ? path : "DejaVuSans";
}

void text(OIIO::ImageBuf& img, int x, int y, const std::string& s, int size,
          OIIO::ImageBufAlgo::TextAlignX ax = OIIO::ImageBufAlgo::TextAlignX::Left) {
  const float black[3] = {0.0f, 0.0f, 0.0f};
  if (!IBA::render_text(img, x, y, s, size, font(), black, ax))
    throw IoError("heatmap: cannot render text with font DejaVuSans (install fonts-dejavu-core): " +
                  img.geterror());
}

/// Encodes the PNG in memory (OIIO's IO proxy); write_png writes it with write_file_atomic:
/// OIIO's PNG writer does not report a failed write to a full disk (a 0-byte and a truncated PNG
/// were left with success), write_file_atomic checks every write and names the reason.
std::string png_bytes(const OIIO::ImageBuf& img, const std::string& name) {
  std::vector<unsigned char> bytes;
  OIIO::Filesystem::IOVecOutput proxy(bytes);
  auto out = OIIO::ImageOutput::create("png");
  OIIO::ImageSpec spec = img.spec();
  spec.set_format(OIIO::TypeDesc::UINT8);
  if (!out || !out->set_ioproxy(&proxy) || !out->open(name, spec) || !img.write(out.get()) ||
      !out->close() || bytes.empty()) {
    throw IoError(name + ": cannot encode PNG: " + (out ? out->geterror() : OIIO::geterror()));
  }
  return std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size());
}

void write_png(const OIIO::ImageBuf& img, const std::filesystem::path& png) {
  if (png.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(png.parent_path(), ec);
    if (ec) {
      throw IoError(fmt::format("{}: cannot create the folder: {}", png.parent_path().string(),
                                ec.message()));
    }
  }
  write_file_atomic(png, png_bytes(img, png.string()));
}

OIIO::ImageBuf to_buf(const SplatImage& s) {
  OIIO::ImageBuf b(OIIO::ImageSpec(s.width, s.height, 3, OIIO::TypeDesc::FLOAT));
  for (int y = 0; y < s.height; ++y)
    for (int x = 0; x < s.width; ++x)
      b.setpixel(x, y, s.rgb.data() + 3 * static_cast<std::size_t>(y * s.width + x), 3);
  return b;
}

// Camera of view v: (u, v, depth) of a point relative to the frame centre; smaller depth is
// nearer to the camera.
Eigen::Vector3f view_coords(int view, const Eigen::Vector3f& d) {
  switch (view) {
    case 0:
      return {d.x(), d.y(), -d.z()};  // front, camera on +z
    case 1:
      return {-d.z(), d.y(), -d.x()};  // right, camera on +x
    case 2:
      return {-d.x(), d.y(), d.z()};  // back, camera on -z
    case 3:
      return {d.x(), -d.z(), -d.y()};  // top, camera on +y
    default: {                         // iso, camera on +(1, 1, 1), y up
      const float s2 = std::sqrt(2.0f), s3 = std::sqrt(3.0f), s6 = std::sqrt(6.0f);
      return {(d.x() - d.z()) / s2, (2.0f * d.y() - d.x() - d.z()) / s6,
              -(d.x() + d.y() + d.z()) / s3};
    }
  }
}

/// The unit vector from the frame towards the camera of a view.
Eigen::Vector3f camera_dir(int view) {
  switch (view) {
    case 0:
      return {0, 0, 1};
    case 1:
      return {1, 0, 0};
    case 2:
      return {0, 0, -1};
    case 3:
      return {0, 1, 0};
    default:
      return Eigen::Vector3f(1, 1, 1).normalized();
  }
}

}  // namespace

Eigen::Vector2i heatmap_size(const HeatmapParams& p) {
  return {4 * p.width + kBarColumns, p.height + kTitleRows};
}

Eigen::Vector3f viridis_color(float t) {
  const float tv = std::isnan(t) ? 0.0f : std::clamp(t, 0.0f, 1.0f);
  const int i = std::min(255, static_cast<int>(tv * 256.0f));
  return {kViridis[i][0], kViridis[i][1], kViridis[i][2]};
}

const float (&viridis_table())[256][3] {
  return kViridis;
}

namespace {

// Moreland (2009), sec. 4 and his appendix: Msh is CIELAB in polar form, M = |(L, a, b)|,
// s = acos(L / M), h = atan2(b, a); sRGB (IEC 61966-2-1) <-> XYZ (D65) <-> CIELAB.
Eigen::Vector3d msh_to_srgb(double m, double s, double h) {
  const double l = m * std::cos(s), a = m * std::sin(s) * std::cos(h),
               b = m * std::sin(s) * std::sin(h);
  const double fy = (l + 16.0) / 116.0, fx = fy + a / 500.0, fz = fy - b / 200.0;
  const auto finv = [](double f) {
    return f * f * f > 0.008856 ? f * f * f : (f - 16.0 / 116.0) / 7.787;
  };
  const Eigen::Vector3d xyz(0.95047 * finv(fx), 1.0 * finv(fy), 1.08883 * finv(fz));
  Eigen::Matrix3d to_rgb;
  to_rgb << 3.2406, -1.5372, -0.4986, -0.9689, 1.8758, 0.0415, 0.0557, -0.2040, 1.0570;
  Eigen::Vector3d rgb = to_rgb * xyz;
  for (int c = 0; c < 3; ++c) {
    const double v = rgb[c];
    rgb[c] =
        std::clamp(v > 0.0031308 ? 1.055 * std::pow(v, 1.0 / 2.4) - 0.055 : 12.92 * v, 0.0, 1.0);
  }
  return rgb;
}

/// Moreland's adjust-hue: the hue of an unsaturated end (magnitude m_unsat) spun towards the
/// saturated colour (m, s, h) so the interpolation does not pass through an unintended hue.
double adjust_hue(double m, double s, double h, double m_unsat) {
  if (m >= m_unsat) return h;
  const double spin = s * std::sqrt(m_unsat * m_unsat - m * m) / (m * std::sin(s));
  return h > -std::numbers::pi / 3.0 ? h + spin : h - spin;
}

struct DivergingTable {
  float rgb[256][3];
  DivergingTable() {
    for (int i = 0; i < 256; ++i) {
      const Eigen::Vector3f c = cool_warm(i / 255.0);
      for (int ch = 0; ch < 3; ++ch)
        rgb[i][ch] = c[ch];
    }
  }
};

const DivergingTable& diverging() {
  static const DivergingTable t;
  return t;
}

}  // namespace

Eigen::Vector3f cool_warm(double t) {
  t = std::clamp(t, 0.0, 1.0);
  // The two ends (Moreland's cool-warm) meet at the unsaturated M = max(M1, M2, 88): each half
  // interpolates a saturated end with white, its hue adjusted.
  double m1 = 80.0, s1 = 1.08, h1 = -1.1, m2 = 80.0, s2 = 1.08, h2 = 0.5;
  const double m_mid = std::max({m1, m2, 88.0});
  if (t < 0.5) {
    m2 = m_mid, s2 = 0.0, h2 = adjust_hue(m1, s1, h1, m_mid);
    t = 2.0 * t;
  } else {
    m1 = m_mid, s1 = 0.0, h1 = adjust_hue(m2, s2, h2, m_mid);
    t = 2.0 * t - 1.0;
  }
  return msh_to_srgb((1 - t) * m1 + t * m2, (1 - t) * s1 + t * s2, (1 - t) * h1 + t * h2)
      .cast<float>();
}

Eigen::Vector3f diverging_color(float t) {
  const float tv = std::isnan(t) ? 0.5f : std::clamp(t, 0.0f, 1.0f);
  const int i = std::min(255, static_cast<int>(tv * 256.0f));
  const auto& row = diverging().rgb[i];
  return {row[0], row[1], row[2]};
}

const float (&diverging_table())[256][3] {
  return diverging().rgb;
}

Eigen::Vector3f map_color(float t, ErrorScale scale) {
  return scale == ErrorScale::Signed ? diverging_color(t) : viridis_color(t);
}

double bar_value(double f, double top, ErrorScale scale) {
  return scale == ErrorScale::Signed ? (2.0 * f - 1.0) * top : f * top;
}

Eigen::Vector3f error_color(float e, float range, ErrorScale scale) {
  if (scale == ErrorScale::Signed)
    return diverging_color(0.5f + 0.5f * std::clamp(e / range, -1.0f, 1.0f));
  return viridis_color(std::min(std::abs(e) / range, 1.0f));
}

SplatImage render_splats(const Eigen::Matrix3Xf& positions, const Eigen::Matrix3Xf& normals,
                         const Eigen::VectorXf& errors, const BoundingBox& frame, int view,
                         int width, int height, int splat_radius, float range, bool shaded,
                         ErrorScale colours) {
  if (errors.size() != positions.cols())
    throw InputError("heatmap: " + std::to_string(errors.size()) + " errors for " +
                     std::to_string(positions.cols()) + " points");
  const bool lambert = normals.cols() == positions.cols() && positions.cols() > 0;
  const int w = width, h = height;
  const float scale = 0.95f * static_cast<float>(std::min(w, h)) / frame.diagonal();
  const Eigen::Vector3f centre = frame.center(), cam = camera_dir(view);
  const float half = 0.5f * frame.diagonal();
  SplatImage img;
  img.width = w;
  img.height = h;
  img.rgb.assign(static_cast<std::size_t>(3 * w * h), 1.0f);
  img.covered.assign(static_cast<std::size_t>(w * h), 0);
  std::vector<float> depth(static_cast<std::size_t>(w * h), std::numeric_limits<float>::infinity());
  const int r = splat_radius;
  for (Eigen::Index i = 0; i < positions.cols(); ++i) {
    const Eigen::Vector3f c = view_coords(view, positions.col(i) - centre);
    const int px = static_cast<int>(std::floor(0.5f * w + c.x() * scale));
    const int py = static_cast<int>(std::floor(0.5f * h - c.y() * scale));
    float shade = 1.0f;
    if (shaded && lambert) {
      shade = 0.35f + 0.65f * std::min(1.0f, std::abs(normals.col(i).dot(cam)));
    } else if (shaded) {
      shade = 1.0f - 0.5f * std::clamp((c.z() + half) / (2.0f * half), 0.0f, 1.0f);
    }
    const Eigen::Vector3f colour = error_color(errors[i], range, colours) * shade;
    for (int dy = -r; dy <= r; ++dy)
      for (int dx = -r; dx <= r; ++dx) {
        if (dx * dx + dy * dy > r * r) continue;
        const int x = px + dx, y = py + dy;
        if (x < 0 || y < 0 || x >= w || y >= h) continue;
        const std::size_t k = static_cast<std::size_t>(y * w + x);
        if (c.z() < depth[k]) {  // strict: ties keep the earlier (lower index) point
          depth[k] = c.z();
          img.covered[k] = 1;
          for (int ch = 0; ch < 3; ++ch)
            img.rgb[3 * k + static_cast<std::size_t>(ch)] = colour[ch];
        }
      }
  }
  return img;
}

FigureLayout figure_layout(int width, int height, int rows, int cols) {
  FigureLayout l;
  l.left = 150;
  l.top = 36;
  l.bar_x = width - kBarColumns;
  if (rows < 1 || cols < 1) throw InputError("figure: no cells");
  l.cell_w = (l.bar_x - l.left) / cols;
  l.cell_h = (height - l.top - 24) / rows;
  if (l.cell_w < 16 || l.cell_h < 16)
    throw InputError(
        fmt::format("--size {}x{}: too small for {} x {} cells", width, height, rows, cols));
  return l;
}

namespace {

/// A vertical colour bar, 24 columns wide, from t = 0 at the bottom (y1) to t = 1 at the top
/// (y0), a heading above it and a footnote below. Magnitude: viridis, five ticks labelled
/// k/4 x top; Signed: cool-warm, ticks from -top to +top.
struct ColourBar {
  int x, y0, y1;
  double top;
  int precision, tick_size;
  std::string heading;
  int heading_size;
  std::string footnote;
  int footnote_size;
  ErrorScale scale = ErrorScale::Magnitude;
};

void draw_colour_bar(OIIO::ImageBuf& img, const ColourBar& b) {
  for (int y = 0; y < b.y1 - b.y0; ++y) {
    const float t = 1.0f - static_cast<float>(y) / static_cast<float>(b.y1 - b.y0 - 1);
    const Eigen::Vector3f c = map_color(t, b.scale);
    IBA::fill(img, c.data(), OIIO::ROI(b.x, b.x + 24, b.y0 + y, b.y0 + y + 1));
  }
  for (int k = 0; k <= 4; ++k) {
    const double frac = k / 4.0;
    const int y = b.y1 - static_cast<int>(frac * (b.y1 - b.y0 - 1));
    text(img, b.x + 28, y + 4, fmt::format("{:.{}g}", bar_value(frac, b.top, b.scale), b.precision),
         b.tick_size);
  }
  text(img, b.x, b.y0 - 6, b.heading, b.heading_size);
  text(img, b.x, b.y1 + 16, b.footnote, b.footnote_size);
}

}  // namespace

void write_figure_png(const std::vector<SplatImage>& cells, const std::vector<std::string>& rows,
                      const std::vector<std::string>& cols, const std::string& title,
                      double saturation, const std::string& unit, int width, int height,
                      const std::filesystem::path& png, ErrorScale scale) {
  const FigureLayout l =
      figure_layout(width, height, static_cast<int>(rows.size()), static_cast<int>(cols.size()));
  const float white[3] = {1.0f, 1.0f, 1.0f}, grey[3] = {0.6f, 0.6f, 0.6f};
  OIIO::ImageBuf img(OIIO::ImageSpec(width, height, 3, OIIO::TypeDesc::FLOAT));
  IBA::fill(img, white);
  const int y0 = l.top + 24;
  for (std::size_t i = 0; i < rows.size(); ++i)
    for (std::size_t j = 0; j < cols.size(); ++j) {
      const SplatImage& c = cells[i * cols.size() + j];
      const int x = l.left + static_cast<int>(j) * l.cell_w,
                y = y0 + static_cast<int>(i) * l.cell_h;
      if (c.width > 0) IBA::paste(img, x, y, 0, 0, to_buf(c));
      if (j > 0) IBA::fill(img, grey, OIIO::ROI(x, x + 1, y, y + l.cell_h));
      if (i > 0) IBA::fill(img, grey, OIIO::ROI(x, x + l.cell_w, y, y + 1));
    }
  for (std::size_t j = 0; j < cols.size(); ++j)
    text(img, l.left + static_cast<int>(j) * l.cell_w + l.cell_w / 2, l.top + 18, cols[j], 14,
         OIIO::ImageBufAlgo::TextAlignX::Center);
  for (std::size_t i = 0; i < rows.size(); ++i)
    text(img, 8, y0 + static_cast<int>(i) * l.cell_h + l.cell_h / 2 + 5, rows[i], 14);
  text(img, 8, 24, title, 16);
  draw_colour_bar(img,
                  {l.bar_x + 12, y0 + 20, height - 30, saturation, 3, 11, unit, 11,
                   scale == ErrorScale::Signed ? "ends: saturated" : "top: saturated", 10, scale});
  write_png(img, png);
}

std::string encode_png(const SplatImage& img) {
  return png_bytes(to_buf(img), "cell.png");
}

void write_heatmap(const PointCloud& points, const Eigen::VectorXf& errors,
                   const BoundingBox& frame, float diagonal, const HeatmapParams& p,
                   const std::filesystem::path& png, const std::string& title) {
  if (errors.size() != points.size())
    throw InputError("heatmap: " + std::to_string(errors.size()) + " errors for " +
                     std::to_string(points.size()) + " points");
  if (!errors.allFinite()) throw InputError("heatmap: an error value is not finite");
  if (frame.empty() || !(diagonal > 0.0f)) throw InputError("heatmap: empty frame");
  const Eigen::Vector2i size = heatmap_size(p);
  const int w = p.width, h = p.height;
  const float range = static_cast<float>(p.range) * diagonal;

  // The four views side by side, unshaded.
  const float white[3] = {1.0f, 1.0f, 1.0f};
  OIIO::ImageBuf coloured(OIIO::ImageSpec(4 * w, h, 3, OIIO::TypeDesc::FLOAT));
  for (int view = 0; view < 4; ++view) {
    const SplatImage v = render_splats(points.positions, Eigen::Matrix3Xf(), errors, frame, view, w,
                                       h, p.splat_radius, range, false);
    IBA::paste(coloured, view * w, 0, 0, 0, to_buf(v));
  }

  OIIO::ImageBuf img(OIIO::ImageSpec(size.x(), size.y(), 3, OIIO::TypeDesc::FLOAT));
  IBA::fill(img, white);
  IBA::paste(img, 0, kTitleRows, 0, 0, coloured);
  const char* names[4] = {"front (+z)", "right (+x)", "back (-z)", "top (+y)"};
  for (int view = 0; view < 4; ++view) {
    text(img, view * w + 6, kTitleRows + 16, names[view], 13);
    if (view > 0) {  // thin separators between views
      const float grey[3] = {0.6f, 0.6f, 0.6f};
      IBA::fill(img, grey, OIIO::ROI(view * w, view * w + 1, kTitleRows, kTitleRows + h));
    }
  }
  text(img, 8, 27, title, 18);

  draw_colour_bar(img, {4 * w + 12, kTitleRows + 20, kTitleRows + h - 20, p.range, 4, 12,
                        "|E| / diag", 12, fmt::format(">= {:.3g} sat.", p.range), 11});
  write_png(img, png);
}

void write_histogram_image(const Json& hist, const std::filesystem::path& png,
                           const std::string& title, int width, int height) {
  if (!hist.is_object() || !hist.contains("counts") || !hist["counts"].is_array())
    throw InputError("histogram image: not a histogram record");
  const auto counts = hist["counts"].get<std::vector<std::int64_t>>();
  if (counts.empty()) throw InputError("histogram image: no bins");
  const std::int64_t top =
      std::max<std::int64_t>(1, *std::max_element(counts.begin(), counts.end()));
  OIIO::ImageBuf img(OIIO::ImageSpec(width, height, 3, OIIO::TypeDesc::FLOAT));
  const float white[3] = {1.0f, 1.0f, 1.0f};
  const float bar[3] = {0.2f, 0.35f, 0.7f};
  const float axis[3] = {0.0f, 0.0f, 0.0f};
  IBA::fill(img, white);
  const int x0 = 60, x1 = width - 20, y0 = 40, y1 = height - 50;
  const double bw = static_cast<double>(x1 - x0) / static_cast<double>(counts.size());
  for (std::size_t b = 0; b < counts.size(); ++b) {
    const int bh = static_cast<int>(std::lround(static_cast<double>(counts[b]) / top * (y1 - y0)));
    if (bh <= 0) continue;
    const int xa = x0 + static_cast<int>(b * bw),
              xb = std::max(xa + 1, x0 + static_cast<int>((b + 1) * bw) - 1);
    IBA::fill(img, bar, OIIO::ROI(xa, xb, y1 - bh, y1));
  }
  IBA::fill(img, axis, OIIO::ROI(x0 - 1, x1, y1, y1 + 1));
  IBA::fill(img, axis, OIIO::ROI(x0 - 1, x0, y0, y1));
  const std::string unit = hist.value("unit", std::string());
  text(img, 8, 26, title, 16);
  text(img, x0, y1 + 18, fmt::format("{:.4g}", hist.value("min", 0.0)), 12);
  text(img, x1, y1 + 18, fmt::format("{:.4g}", hist.value("max", 0.0)), 12,
       OIIO::ImageBufAlgo::TextAlignX::Right);
  text(img, (x0 + x1) / 2, y1 + 18, unit, 12, OIIO::ImageBufAlgo::TextAlignX::Center);
  text(img, x0, y1 + 38,
       fmt::format("count {}  overflow {}  peak bin {}", hist.value("count", std::int64_t{0}),
                   hist.value("overflow", std::int64_t{0}), top),
       12);
  write_png(img, png);
}

}  // namespace scanbench::metrics
