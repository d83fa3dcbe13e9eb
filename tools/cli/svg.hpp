// A small hand-written SVG writer for the tool's pictures (no plotting library is installed):
// a document of lines, polylines, circles, rectangles and text, and Axes that map data to pixels
// and draw a framed plot with ticks.
#pragma once

#include <glovepose/config.hpp>
#include <glovepose/io/atomic_file.hpp>

#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

namespace glovepose::cli::svg {

/// @brief A point in pixels.
using Point = std::pair<double, double>;

/// @brief One SVG picture, built element by element and written with save().
class Document {
 public:
  Document(double width, double height) : width_(width), height_(height) { rect(0, 0, width, height, "white"); }

  void line(double x1, double y1, double x2, double y2, const std::string& stroke, double width = 1.0, const std::string& dash = "") {
    body_ += "<line x1=\"" + num(x1) + "\" y1=\"" + num(y1) + "\" x2=\"" + num(x2) + "\" y2=\"" + num(y2) + "\"" +
             stroke_attributes(stroke, width, dash) + "/>\n";
  }

  void polyline(const std::vector<Point>& points, const std::string& stroke, double width = 1.0, const std::string& dash = "") {
    if (points.empty()) return;
    body_ += "<polyline fill=\"none\"" + stroke_attributes(stroke, width, dash) + " points=\"";
    for (std::size_t i = 0; i < points.size(); ++i) body_ += (i ? " " : "") + num(points[i].first) + "," + num(points[i].second);
    body_ += "\"/>\n";
  }

  void circle(double cx, double cy, double r, const std::string& fill) {
    body_ += "<circle cx=\"" + num(cx) + "\" cy=\"" + num(cy) + "\" r=\"" + num(r) + "\" fill=\"" + fill + "\"/>\n";
  }

  void rect(double x, double y, double w, double h, const std::string& fill, const std::string& stroke = "none") {
    body_ += "<rect x=\"" + num(x) + "\" y=\"" + num(y) + "\" width=\"" + num(w) + "\" height=\"" + num(h) + "\" fill=\"" + fill +
             "\" stroke=\"" + stroke + "\"/>\n";
  }

  /// `anchor`: start, middle or end; `rotate`: degrees about (x, y), e.g. -90 for a y-axis label.
  void text(double x, double y, const std::string& content, double size = 12.0, const std::string& anchor = "start",
            const std::string& fill = "black", double rotate = 0.0) {
    body_ += "<text x=\"" + num(x) + "\" y=\"" + num(y) + "\" font-size=\"" + num(size) + "\" text-anchor=\"" + anchor + "\" fill=\"" +
             fill + "\"" + (rotate != 0.0 ? " transform=\"rotate(" + num(rotate) + " " + num(x) + " " + num(y) + ")\"" : "") + ">" +
             escape(content) + "</text>\n";
  }

  /// Writes the picture, whole or not at all; throws glovepose::Error naming the file and the cause
  /// when it cannot be written.
  void save(const std::string& path) const {
    io::write_file_whole(path, "picture", [&](std::ostream& file) {
      file << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
           << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << num(width_) << "\" height=\"" << num(height_) << "\" viewBox=\"0 0 "
           << num(width_) << " " << num(height_) << "\" font-family=\"sans-serif\">\n"
           << body_ << "</svg>\n";
    });
  }

  /// A coordinate or size with one decimal: a tenth of a pixel is below what a screen shows.
  static std::string num(double v) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.1f", std::abs(v) < 0.05 ? 0.0 : v);
    return buffer;
  }

 private:
  static std::string stroke_attributes(const std::string& stroke, double width, const std::string& dash) {
    return " stroke=\"" + stroke + "\" stroke-width=\"" + num(width) + "\"" + (dash.empty() ? "" : " stroke-dasharray=\"" + dash + "\"") +
           " stroke-linejoin=\"round\" stroke-linecap=\"round\"";
  }

  static std::string escape(const std::string& text) {
    std::string out;
    for (char c : text) {
      if (c == '&')
        out += "&amp;";
      else if (c == '<')
        out += "&lt;";
      else if (c == '>')
        out += "&gt;";
      else
        out += c;
    }
    return out;
  }

  double width_, height_;
  std::string body_;
};

/// @brief A framed plot area of a document: data coordinates in, pixels out.
class Axes {
 public:
  /// The area's pixel rectangle and the data ranges it shows.
  Axes(Document& document, double left, double top, double width, double height, double x_min, double x_max, double y_min, double y_max)
      : doc_(document), left_(left), top_(top), width_(width), height_(height), x_min_(x_min), x_max_(x_max), y_min_(y_min), y_max_(y_max) {
    if (!(x_max > x_min) || !(y_max > y_min))
      throw Error("svg::Axes: empty data range [" + std::to_string(x_min) + ", " + std::to_string(x_max) + "] x [" + std::to_string(y_min) +
                  ", " + std::to_string(y_max) + "], expected max > min on both axes");
  }

  double px(double x) const { return left_ + (x - x_min_) / (x_max_ - x_min_) * width_; }
  double py(double y) const { return top_ + height_ - (y - y_min_) / (y_max_ - y_min_) * height_; }

  /// Frame, grid lines and tick labels every `x_step` / `y_step` data units, axis labels and a title.
  void draw(double x_step, double y_step, const std::string& x_label, const std::string& y_label, const std::string& title) {
    // Ticks at whole multiples of the step; the small slack keeps the range's own ends.
    for (double x = std::ceil(x_min_ / x_step) * x_step; x <= x_max_ + 1e-9 * x_step; x += x_step) {
      doc_.line(px(x), top_, px(x), top_ + height_, "#e0e0e0");
      doc_.text(px(x), top_ + height_ + 14, tick(x), 11, "middle");
    }
    for (double y = std::ceil(y_min_ / y_step) * y_step; y <= y_max_ + 1e-9 * y_step; y += y_step) {
      doc_.line(left_, py(y), left_ + width_, py(y), "#e0e0e0");
      doc_.text(left_ - 5, py(y) + 4, tick(y), 11, "end");
    }
    doc_.rect(left_, top_, width_, height_, "none", "#404040");
    if (!x_label.empty()) doc_.text(left_ + width_ / 2, top_ + height_ + 30, x_label, 12, "middle");
    if (!y_label.empty()) doc_.text(left_ - 36, top_ + height_ / 2, y_label, 12, "middle", "black", -90);
    if (!title.empty()) doc_.text(left_, top_ - 6, title, 13);
  }

  /// A line through the data points (xs[i], ys[i]).
  void plot(const std::vector<double>& xs, const std::vector<double>& ys, const std::string& stroke, double width = 1.2,
            const std::string& dash = "") {
    std::vector<Point> points;
    points.reserve(xs.size());
    for (std::size_t i = 0; i < xs.size() && i < ys.size(); ++i) points.emplace_back(px(xs[i]), py(ys[i]));
    doc_.polyline(points, stroke, width, dash);
  }

  /// A legend entry (a short line and its label) at row `row` inside the area's top-left corner.
  void legend(int row, const std::string& stroke, const std::string& label, const std::string& dash = "") {
    const double y = top_ + 14 + 16 * row;
    doc_.line(left_ + 8, y - 4, left_ + 30, y - 4, stroke, 2.0, dash);
    doc_.text(left_ + 36, y, label, 11);
  }

 private:
  static std::string tick(double v) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%g", std::abs(v) < 1e-9 ? 0.0 : v);
    return buffer;
  }

  Document& doc_;
  double left_, top_, width_, height_, x_min_, x_max_, y_min_, y_max_;
};

}  // namespace glovepose::cli::svg
