// track.png: the run seen from above, readable without the code. The floor drawn to scale with
// metre axes and a 1 m scale bar; a title naming the scenario, its seed and duration; the zone
// boxes (each intersection's area labelled with its id, its stop boxes thinner); the obstacles;
// each car's path in its colour with its start (a filled dot) and arrows every 2 m of its first
// 12 m showing the direction of travel; collisions as red crosses where the car was; a legend.
#pragma once

#include <opencv2/core.hpp>

#include "sim/scenario/run_record.h"
#include "sim/scenario/scenario.h"
#include "world/track.h"

namespace autonomsim::sim {

// Where the floor sits on the figure: the figure's pixel of a map point (metres).
struct TrackFigureLayout {
  double m_per_px{0.005};
  double x0_m{0.0};  // map x of the floor's left edge
  double y0_m{0.0};  // map y of the floor's top edge
  int left_px{0};    // the floor's top-left corner on the figure
  int top_px{0};
  cv::Point ToPixel(double x_m, double y_m) const;
};

TrackFigureLayout TrackFigureLayoutOf(const LoadedScenario& loaded);

// The figure, BGR8. Reads the record's samples and events once each.
cv::Mat DrawTrackFigure(const LoadedScenario& loaded, const RunRecord& record);

// The pieces, for figures drawn over time (the video): what does not change during a run
// (background, floor, zone boxes, the obstacles if `with_obstacles`, axes, scale bar, title),
// where the floor sits, and where the legend goes.
struct TrackFigureBase {
  cv::Mat image;
  TrackFigureLayout layout;
  int legend_x{0};
};
TrackFigureBase DrawTrackFigureBase(const Scenario& scenario, const world::Track& track,
                                    bool with_obstacles);
// The legend at x = legend_x: each car in its colour (a line if `paths`, else a box), then the
// marks. Returns the y below it.
int DrawTrackLegend(cv::Mat& image, const Scenario& scenario, int legend_x, bool paths);
void DrawObstacle(cv::Mat& image, const TrackFigureLayout& at, const ObstacleConfig& o);
void DrawCollisionMarker(cv::Mat& image, cv::Point p);

// Car `car_id`'s colour in every figure of a run (track.png, the report, the video), BGR: by the
// car's place in the scenario, from a palette that stands out on black, white and yellow.
cv::Scalar CarColourBgr(const Scenario& scenario, int car_id);
// The palette's colour for the car at `index` in the scenario.
cv::Scalar CarColourBgrAt(std::size_t index);
// A BGR colour as "#rrggbb" (for the report's page and gnuplot scripts).
std::string ColourHex(const cv::Scalar& bgr);

// The colour of collision markers (BGR).
inline const cv::Scalar kCollisionMarkerBgr(0, 0, 255);

}  // namespace autonomsim::sim
