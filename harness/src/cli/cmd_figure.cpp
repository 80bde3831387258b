// scanbench figure DIR -o FILE.png|.svg|.pdf [--metric p2plane] [--datasets a,b]
//   [--variants x,y] [--view front|iso|top|side] [--size WxH] [--point P] [--max M] [--flat]
//   [--signed]
#include <fmt/format.h>

#include <sstream>

#include "cli/commands.h"
#include "scanbench/core/errors.h"
#include "scanbench/harness/results/figure.h"

namespace scanbench::harness {

namespace {

std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace

void add_figure_command(Cli& cli) {
  struct Args {
    FigureOptions o;
    std::string dir, out, datasets, variants, size = "1200x800";
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = cli.app.add_subcommand(
      "figure",
      "Write a static figure grid for print (PNG, SVG with embedded cells, or PDF): rows "
      "datasets, columns variants, each cell the output coloured by |E| in viridis (or the "
      "signed E in a diverging map) on one scale");
  sub->add_option("dir", a->dir, "Results folder")->required();
  sub->add_option("-o,--out", a->out, "Figure file, .png, .svg or .pdf")->required();
  sub->add_option("--metric", a->o.metric, "Per-point error to colour by (p2plane)")
      ->capture_default_str();
  sub->add_option("--datasets", a->datasets, "Rows, comma-separated (default: every dataset)");
  sub->add_option("--variants", a->variants, "Columns, comma-separated (default: every variant)");
  sub->add_option("--view", a->o.view, "Camera: front, iso, top or side")->capture_default_str();
  sub->add_option("--size", a->size, "Figure size in pixels, WxH")->capture_default_str();
  sub->add_option("--point", a->o.point, "Sweep point label (default: the first)");
  sub->add_option("--max", a->o.max,
                  "Colour saturation, |E| / diagonal (default: 95th percentile of all cells)");
  sub->add_flag("--flat", a->o.flat, "Unshaded: every pixel exactly a colour-map entry");
  sub->add_flag("--signed", a->o.signed_errors,
                "Colour by the signed error E (- inside, + outside) in Moreland's cool-warm "
                "diverging map, from -max to +max");
  sub->callback([&cli, a] {
    cli.action = [a] {
      FigureOptions o = a->o;
      o.dir = a->dir;
      o.out = a->out;
      o.datasets = split_list(a->datasets);
      o.variants = split_list(a->variants);
      int w = 0, h = 0;
      char x = 0, rest = 0;
      std::istringstream in(a->size);
      if (!(in >> w >> x >> h) || x != 'x' || in >> rest || w < 200 || h < 100 || w > 16384 ||
          h > 16384)
        throw InputError("--size " + a->size + ": not WxH pixels (200..16384 x 100..16384)");
      o.width = w;
      o.height = h;
      const FigureSummary s = write_figure(o);
      fmt::print("{}: {} x {} cells, saturation {:.4g} x diagonal ({})\n", o.out.string(),
                 s.rows.size(), s.cols.size(), s.saturation,
                 s.percentile ? "95th percentile" : "--max");
      return 0;
    };
  });
}

}  // namespace scanbench::harness
