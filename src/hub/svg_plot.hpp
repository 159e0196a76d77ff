// Internal: small SVG charts for the HTML report (line charts, histograms, x-y paths).
#pragma once

#include <string>
#include <vector>

namespace scaratwin::svg {

struct Series {
  std::string name;
  std::string color;
  std::vector<double> x;
  std::vector<double> y;
  bool dashed = false;
};

// Line chart with axes, ticks and a legend. `equal_aspect` keeps metres square (path views).
std::string line_chart(const std::string& title, const std::string& x_label,
                       const std::string& y_label, const std::vector<Series>& series,
                       int width = 460, int height = 260, bool equal_aspect = false);

// Histogram of `values` in `bins` bins.
std::string histogram(const std::string& title, const std::string& x_label,
                      const std::vector<double>& values, int bins = 40, int width = 460,
                      int height = 260);

}  // namespace scaratwin::svg
