// CalculiX (ccx) as an independent reference for static linear analysis: write a C3D4 input deck
// (*NODE, *ELEMENT, *MATERIAL/*ELASTIC, *BOUNDARY, *CLOAD, *STEP/*STATIC, *NODE PRINT U,
// *EL PRINT S), run `ccx -i job` in a folder, and read the displacements and stresses of its .dat.
// Nodes and elements are numbered by index + 1 in the deck.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "shatter/core/types.h"
#include "shatter/mesh/tet_mesh.h"

namespace shatter::calculix {

struct Deck {
  const TetMesh* mesh = nullptr;
  double youngs_modulus = 0;  ///< Pa
  double poisson_ratio = 0;
  std::vector<std::uint8_t> held;             ///< held components per node, bit c = component c (#nodes)
  std::vector<Vec3> prescribed_displacement;  ///< of held components, m (#nodes; empty = zero)
  std::vector<Vec3> forces;                   ///< nodal forces, N (#nodes)
  /// Geometrically non-linear (NLGEOM): *ELASTIC is then St. Venant-Kirchhoff (the second
  /// Piola-Kirchhoff stress linear in the Green strain), CLOADs are dead loads.
  bool nlgeom = false;
  double initial_increment = 1.0;  ///< NLGEOM: first increment of the unit step period
  /// NLGEOM: *CONTROLS field tolerances R_n (residual against the average force) and C_n
  /// (correction against the increment's displacement); 0 = CalculiX's defaults (0.005, 0.01).
  double residual_control = 0;
};

/// True when a `ccx` program is on the PATH.
inline bool available() { return std::system("command -v ccx > /dev/null 2>&1") == 0; }

inline std::string deck_text(const Deck& d) {
  std::string s;
  char buf[256];
  s += "*HEADING\nshatter cross-check\n*NODE, NSET=NALL\n";
  const TetMesh& m = *d.mesh;
  for (Index i = 0; i < m.num_nodes(); ++i) {
    const Vec3& p = m.positions[i];
    std::snprintf(buf, sizeof buf, "%d, %.17g, %.17g, %.17g\n", i + 1, p.x(), p.y(), p.z());
    s += buf;
  }
  s += "*ELEMENT, TYPE=C3D4, ELSET=EALL\n";
  for (Index e = 0; e < m.num_tets(); ++e) {
    const TetIndices& t = m.tets[e];
    std::snprintf(buf, sizeof buf, "%d, %d, %d, %d, %d\n", e + 1, t[0] + 1, t[1] + 1, t[2] + 1, t[3] + 1);
    s += buf;
  }
  s += "*MATERIAL, NAME=MAT\n*ELASTIC\n";
  std::snprintf(buf, sizeof buf, "%.17g, %.17g\n", d.youngs_modulus, d.poisson_ratio);
  s += buf;
  s += "*SOLID SECTION, ELSET=EALL, MATERIAL=MAT\n";
  if (d.nlgeom) {
    s += "*STEP, NLGEOM, INC=10000\n";
    if (d.residual_control > 0) {
      std::snprintf(buf, sizeof buf, "*CONTROLS, PARAMETERS=FIELD\n%.6g, %.6g\n", d.residual_control,
                    d.residual_control);
      s += buf;
    }
    std::snprintf(buf, sizeof buf, "*STATIC\n%.6g, 1.0\n*BOUNDARY\n", d.initial_increment);
    s += buf;
  } else {
    s += "*STEP\n*STATIC\n*BOUNDARY\n";
  }
  for (Index i = 0; i < m.num_nodes(); ++i)
    for (int c = 0; c < 3; ++c)
      if (d.held[i] & (1u << c)) {
        const double u = d.prescribed_displacement.empty() ? 0.0 : d.prescribed_displacement[i][c];
        std::snprintf(buf, sizeof buf, "%d, %d, %d, %.17g\n", i + 1, c + 1, c + 1, u);
        s += buf;
      }
  s += "*CLOAD\n";
  for (Index i = 0; i < m.num_nodes(); ++i)
    for (int c = 0; c < 3; ++c)
      if (d.forces[i][c] != 0.0) {
        std::snprintf(buf, sizeof buf, "%d, %d, %.17g\n", i + 1, c + 1, d.forces[i][c]);
        s += buf;
      }
  s += "*NODE PRINT, NSET=NALL\nU\n*EL PRINT, ELSET=EALL\nS\n*END STEP\n";
  return s;
}

struct Solution {
  std::vector<Vec3> displacement;  ///< m (#nodes)
  std::vector<Mat3> stress;        ///< Pa, at the single integration point of each C3D4 (#tets)
  std::string error;               ///< "" on success
  int increments = 0;              ///< converged increments (from ccx's log)
  int iterations = 0;              ///< equilibrium iterations over all attempts (from ccx's log)
  double seconds = 0;              ///< wall time of the ccx run, s
};

/// Count "increment N attempt M" (converged increments are the distinct N) and "iteration K"
/// lines of ccx's standard output.
inline void count_iterations(const std::string& log, Solution& s) {
  std::istringstream in(log);
  int last_increment = 0;
  for (std::string line; std::getline(in, line);) {
    std::istringstream ls(line);
    std::string word;
    ls >> word;
    if (word == "increment") {
      int n = 0;
      if (ls >> n) last_increment = std::max(last_increment, n);
    } else if (word == "iteration") {
      ++s.iterations;
    }
  }
  s.increments = last_increment;
}

/// Parse the .dat blocks "displacements (vx,vy,vz) ..." and "stresses (elem, integ.pnt.,sxx,syy,szz,
/// sxy,sxz,syz) ...".
inline Solution parse_dat(const std::string& text, Index num_nodes, Index num_tets) {
  Solution s;
  s.displacement.assign(static_cast<std::size_t>(num_nodes), Vec3::Constant(std::nan("")));
  s.stress.assign(static_cast<std::size_t>(num_tets), Mat3::Constant(std::nan("")));
  std::istringstream in(text);
  enum { none, disp, stress } block = none;
  Index nodes_read = 0, tets_read = 0;
  for (std::string line; std::getline(in, line);) {
    // A non-linear step prints every increment: the last block of each kind is the result.
    if (line.find("displacements (vx,vy,vz)") != std::string::npos) {
      block = disp;
      nodes_read = 0;
      continue;
    }
    if (line.find("stresses (elem, integ.pnt.") != std::string::npos) {
      block = stress;
      tets_read = 0;
      continue;
    }
    std::istringstream ls(line);
    if (block == disp) {
      long id = 0;
      double u[3];
      if (ls >> id >> u[0] >> u[1] >> u[2]) {
        if (id < 1 || id > num_nodes) {
          s.error = "node " + std::to_string(id) + " out of range";
          return s;
        }
        s.displacement[static_cast<std::size_t>(id - 1)] = Vec3(u[0], u[1], u[2]);
        ++nodes_read;
      }
    } else if (block == stress) {
      long id = 0, ip = 0;
      double v[6];
      if (ls >> id >> ip >> v[0] >> v[1] >> v[2] >> v[3] >> v[4] >> v[5]) {
        if (id < 1 || id > num_tets) {
          s.error = "element " + std::to_string(id) + " out of range";
          return s;
        }
        Mat3& m = s.stress[static_cast<std::size_t>(id - 1)];
        m << v[0], v[3], v[4], v[3], v[1], v[5], v[4], v[5], v[2];  // sxy, sxz, syz
        ++tets_read;
      }
    }
  }
  if (nodes_read != num_nodes || tets_read != num_tets)
    s.error = "read " + std::to_string(nodes_read) + " displacements and " + std::to_string(tets_read) +
              " stresses, expected " + std::to_string(num_nodes) + " and " + std::to_string(num_tets);
  return s;
}

/// Write job.inp in `folder`, run ccx there, parse job.dat.
inline Solution run(const Deck& d, const std::string& folder) {
  {
    std::ofstream out(folder + "/job.inp");
    out << deck_text(d);
  }
  const std::string cmd = "cd '" + folder + "' && OMP_NUM_THREADS=1 ccx -i job > ccx.log 2>&1";
  Solution s;
  const auto start = std::chrono::steady_clock::now();
  const int status = std::system(cmd.c_str());
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (status != 0) {
    s.error = "ccx failed; see " + folder + "/ccx.log";
    return s;
  }
  {
    std::ifstream log(folder + "/ccx.log");
    std::stringstream text;
    text << log.rdbuf();
    count_iterations(text.str(), s);
  }
  std::ifstream in(folder + "/job.dat");
  if (!in) {
    s.error = "ccx wrote no job.dat; see " + folder + "/ccx.log";
    return s;
  }
  std::stringstream text;
  text << in.rdbuf();
  Solution parsed = parse_dat(text.str(), d.mesh->num_nodes(), d.mesh->num_tets());
  parsed.increments = s.increments;
  parsed.iterations = s.iterations;
  parsed.seconds = s.seconds;
  return parsed;
}

}  // namespace shatter::calculix
