#include "jobs/fit_benchmark_report.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <map>
#include <sstream>
#include <string>

namespace aqs {
namespace fit_benchmark {

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double Max(const std::vector<double>& v) {
  return v.empty() ? 0 : *std::max_element(v.begin(), v.end());
}

double Mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / v.size();
}

std::string Fixed(double value, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << value;
  return s.str();
}

}  // namespace fit_benchmark

using fit_benchmark::Fixed;
using fit_benchmark::Max;
using fit_benchmark::Mean;
using fit_benchmark::Median;

namespace {

// A fit that failed (no result: its errors are NaN, its other figures 0): left out of
// every statistic, and counted where the table says how many failed.
bool Failed(const FitBenchmarkRow& row) { return !std::isfinite(row.mean); }

// " (N failed)" where N > 0, else "".
std::string FailedNote(int failed) {
  return failed > 0 ? " (" + std::to_string(failed) + " failed)" : "";
}

}  // namespace

std::string FitBenchmarkTables(const std::vector<FitBenchmarkRow>& rows,
                               const FitBenchmarkParts& parts, size_t num_measured) {
  auto select = [&](const std::string& method, int markers) {
    std::map<std::string, FitBenchmarkRow> by_mix;
    for (const FitBenchmarkRow& r : rows) {
      if (r.method == method && r.markers == markers) by_mix[r.mix] = r;
    }
    return by_mix;
  };
  std::ostringstream md;
  const std::map<std::string, FitBenchmarkRow> neutral = select("neutral", 0);
  if (parts.markers) {
    md << "| markers | neutral | ridge PCA | physics | physics < PCA | PCA > neutral | physics > "
          "neutral | physics worst / neutral | fit s median | max | factorizations median |\n"
       << "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
    for (int k : parts.marker_counts) {
      const auto p = select("pca", k), f = select("physics", k);
      std::vector<double> n_err, p_err, f_err, secs, work;
      int better = 0, pca_worse = 0, phys_worse = 0, failed = 0;
      double worst_ratio = 0;
      for (const auto& [mix, row] : f) {
        // Rows come per mix in order neutral, PCA, physics; a mix without them (a run
        // stopped in between) is left out rather than looked up.
        if (!neutral.count(mix) || !p.count(mix)) continue;
        if (Failed(row)) {
          ++failed;
          continue;
        }
        n_err.push_back(neutral.at(mix).mean);
        p_err.push_back(p.at(mix).mean);
        f_err.push_back(row.mean);
        secs.push_back(row.seconds);
        work.push_back(row.factorizations + row.jacobians);
        better += row.mean < p.at(mix).mean;
        pca_worse += p.at(mix).mean > neutral.at(mix).mean;
        phys_worse += !(row.mean <= neutral.at(mix).mean);
        worst_ratio = std::max(worst_ratio, row.mean / neutral.at(mix).mean);
      }
      const int n = static_cast<int>(f_err.size());
      md << "| " << k << " | " << Fixed(Mean(n_err), 4) << " | " << Fixed(Mean(p_err), 4) << " | "
         << Fixed(Mean(f_err), 4) << FailedNote(failed) << " | " << better << " of " << n
         << " | " << pca_worse << " | "
         << phys_worse << " | " << Fixed(worst_ratio, 2) << " | " << Fixed(Median(secs), 2)
         << " | " << Fixed(Max(secs), 2) << " | "
         << Fixed(Median(work), 0) << " |\n";
    }
    md << "\n";
  }
  if (parts.poses || parts.scans) {
    const auto pose = select("physics_pose", 0), scan = select("physics_scan", 0),
               scan_landmarks = select("physics_scan_landmarks", 0),
               scan_from_pose = select("physics_scan_from_pose", 0),
               pca_pose = select("pca_pose", 0);
    md << "| fit | mean error | max of mean errors | seconds median | max | iterations median | "
          "factorizations median |\n"
       << "| --- | ---: | ---: | ---: | ---: | ---: | ---: |\n";
    for (const auto& [name, set] :
         {std::make_pair(std::string("full correspondence"), pose),
          std::make_pair(std::string("scan"), scan),
          std::make_pair(std::string("scan with landmarks"), scan_landmarks),
          std::make_pair(std::string("scan from the fit with correspondence (diagnostic)"),
                         scan_from_pose)}) {
      if (set.empty()) continue;
      std::vector<double> err, secs, its, work;
      int failed = 0;
      for (const auto& [mix, row] : set) {
        if (Failed(row)) {
          ++failed;
          continue;
        }
        err.push_back(row.mean);
        secs.push_back(row.seconds);
        its.push_back(row.iterations);
        work.push_back(row.factorizations + row.jacobians);
      }
      md << "| " << name << FailedNote(failed) << " | " << Fixed(Mean(err), 4) << " | "
         << Fixed(Max(err), 4) << " | " << Fixed(Median(secs), 2)
         << " | " << Fixed(Max(secs), 2) << " | "
         << Fixed(Median(its), 0) << " | " << Fixed(Median(work), 0) << " |\n";
    }
    if (!pca_pose.empty()) {
      std::vector<double> err;
      for (const auto& [mix, row] : pca_pose) err.push_back(row.mean);
      md << "| PCA projection (reference) | " << Fixed(Mean(err), 4) << " | "
         << Fixed(Max(err), 4) << " | | | | |\n";
    }
    for (const auto& [name, set] :
         {std::make_pair(std::string("Scans"), scan),
          std::make_pair(std::string("Scans with landmarks"), scan_landmarks),
          std::make_pair(std::string("Scans from the fit with correspondence"),
                         scan_from_pose)}) {
      if (pose.empty() || set.empty()) continue;
      int within = 0, missed_minimum = 0, judged = 0, split = 0, beyond = 0, closer_normal = 0;
      int fitted = 0;
      double worst = 0, fraction = 0, distance = 0;
      std::vector<double> seen, normal, tangential, pose_normal, pose_tangential, unseen,
          pose_unseen;
      for (const auto& [mix, row] : set) {
        if (!pose.count(mix)) continue;  // the pose's fit comes first; see above
        if (Failed(row) || Failed(pose.at(mix))) continue;
        ++fitted;
        const double ratio = row.mean / pose.at(mix).mean;
        within += ratio <= 1.2;
        if (ratio > 1.2 && !std::isnan(row.pose_fit_objective_ratio)) {
          ++judged;
          missed_minimum += row.pose_fit_objective_ratio < 1;
        }
        if (row.scanned > 0 && !std::isnan(row.pose_fit_scanned_error.normal)) {
          ++split;
          seen.push_back(row.scanned);
          normal.push_back(row.scanned_error.normal);
          tangential.push_back(row.scanned_error.tangential);
          pose_normal.push_back(row.pose_fit_scanned_error.normal);
          pose_tangential.push_back(row.pose_fit_scanned_error.tangential);
          if (!std::isnan(row.unscanned_error)) {
            unseen.push_back(row.unscanned_error);
            pose_unseen.push_back(row.pose_fit_unscanned_error);
          }
          if (ratio > 1.2) {
            ++beyond;
            closer_normal += row.scanned_error.normal <= row.pose_fit_scanned_error.normal;
          }
        }
        worst = std::max(worst, ratio);
        fraction += row.matched_fraction;
        distance += row.matched_distance;
      }
      if (fitted > 0) {
        fraction /= fitted;
        distance /= fitted;
      }
      md << "\n" << name << " within 1.2x of the fit with correspondence: " << within << " of "
         << set.size() << FailedNote(static_cast<int>(set.size()) - fitted) << "; worst ratio "
         << Fixed(worst, 2) << "; matched points "
         << Fixed(100 * fraction, 1) << "% on average, matched distance " << Fixed(distance, 4)
         << " on average. Of the " << judged << " beyond 1.2x, " << missed_minimum
         << " stopped where the scan's objective is larger than at the fit with "
            "correspondence (a worse minimum), " << judged - missed_minimum
         << " where it is smaller (the scan prefers that pose).";
      if (split > 0) {
        md << " Over the region the scans see (" << Fixed(Mean(seen), 0) << " of the "
           << num_measured << " vertices on average: within " << Fixed(kScannedSpacings, 0)
           << " scan spacings of a scan point), along the true surface's normals the fits are "
              "at " << Fixed(Mean(normal), 4) << " (the fits with correspondence "
           << Fixed(Mean(pose_normal), 4) << "), across them at " << Fixed(Mean(tangential), 4)
           << " (" << Fixed(Mean(pose_tangential), 4) << ")";
        if (!unseen.empty()) {
          md << "; over the vertices they do not see, at " << Fixed(Mean(unseen), 4) << " ("
             << Fixed(Mean(pose_unseen), 4) << ")";
        }
        md << ". Beyond 1.2x and as close to the true surface along its normals there as the fit "
              "with correspondence, or closer (an excess that is a slide along the surface, "
              "which a scan does not measure): " << closer_normal << " of the " << beyond << ".";
      }
      md << "\n";
    }
  }
  if (parts.uncertainty) {
    // How well each kind of fit knows its own error: the predicted standard deviation
    // against the error, and their correlation over the vertices of each fit.
    md << "\n| fit | mean error | predicted standard deviation | correlation over the vertices "
          "(mean of the fits) |\n| --- | ---: | ---: | ---: |\n";
    std::map<std::string, std::vector<const FitBenchmarkRow*>> by_method;
    for (const FitBenchmarkRow& r : rows) {
      if (!std::isnan(r.predicted_std)) {
        by_method[r.method + (r.markers > 0 ? " " + std::to_string(r.markers) : "")].push_back(&r);
      }
    }
    for (const auto& [name, set] : by_method) {
      std::vector<double> err, predicted, correlation;
      for (const FitBenchmarkRow* r : set) {
        err.push_back(r->mean);
        predicted.push_back(r->predicted_std);
        if (!std::isnan(r->std_error_correlation)) correlation.push_back(r->std_error_correlation);
      }
      md << "| " << name << " | " << Fixed(Mean(err), 4) << " | " << Fixed(Mean(predicted), 4)
         << " | " << Fixed(Mean(correlation), 2) << " |\n";
    }
  }
  return md.str();
}

std::string FitBenchmarkCsv(const std::vector<FitBenchmarkRow>& rows) {
  std::ostringstream csv;
  csv << "mix,method,markers,mean_error,max_error,seconds,iterations,converged,jaw_degrees,"
         "matched_fraction,matched_distance,predicted_std,std_error_correlation,"
         "pose_fit_objective_ratio,scanned_vertices,scanned_normal_error,"
         "scanned_tangential_error,pose_fit_scanned_normal_error,"
         "pose_fit_scanned_tangential_error,unscanned_error,pose_fit_unscanned_error,start\n";
  for (const FitBenchmarkRow& r : rows) {
    csv << r.mix << ',' << r.method << ',' << r.markers << ',' << r.mean << ',' << r.max << ','
        << r.seconds << ',' << r.iterations << ',' << r.converged << ',' << r.jaw_degrees << ','
        << r.matched_fraction << ',' << r.matched_distance << ',' << r.predicted_std << ','
        << r.std_error_correlation << "," << r.pose_fit_objective_ratio << ',' << r.scanned << ','
        << r.scanned_error.normal << ',' << r.scanned_error.tangential << ','
        << r.pose_fit_scanned_error.normal << ',' << r.pose_fit_scanned_error.tangential << ','
        << r.unscanned_error << ',' << r.pose_fit_unscanned_error << ",\""
        << r.start
        << "\"\n";  // quoted: it may hold commas
  }
  return csv.str();
}

}  // namespace aqs
