/**
 * @class vtkBalloonSegmentation
 * @brief Seeded balloon segmentation of a vtkImageData into a closed triangle mesh (balloonseg).
 *
 * Input: a vtkImageData whose point scalars (the input array to process, by default the active
 * scalars) are unsigned/signed char, (unsigned) short, (unsigned) int, float or double. Other
 * types are rejected with an error. The voxels are handed to the balloonseg C library without a
 * copy; with several components only the first one is segmented. Spacing, origin and the
 * direction matrix of the image are honoured: index (i, j, k) is at
 * origin + Direction * (spacing * (i, j, k)), as vtkImageData::TransformIndexToPhysicalPoint says.
 *
 * Output: a vtkPolyData in the same world coordinates (double points, outward-oriented triangles,
 * closed, 2-manifold, free of self-intersections) with the point-data array "vertex_state"
 * (unsigned char: 0 moving, 1 frozen at the border, 2 frozen by a self-intersection).
 *
 * Seeds are world coordinates (SetSeed replaces all seeds, AddSeed adds one; at least one is
 * required).
 *
 * Several objects (docs/interfaces.md, "Several objects"): AddLabelledSeed(label, x, y, z) adds a
 * seed of object `label` (1 to 2^31 - 1; SetSeed/AddSeed seeds are object 1); the objects grow
 * together and stop at each other. AddStopSeed(x, y, z) seeds a competitor that keeps the objects
 * out of its structure and is left out of the output. SetRegionOfInterest takes VTK bounds
 * (xmin, xmax, ymin, ymax, zmin, zmax, world mm) of a box no balloon grows beyond. With one
 * object, no stop seed and no region the library's single balloon runs (balloon_init ...
 * balloon_segment) exactly as before; otherwise balloon_segment_objects.
 *
 * Output port 0: all objects in one vtkPolyData, in the order their labels first appear among
 * the seeds, with the Int32 cell array "object" (each triangle's label; present with one object
 * too, then all equal to its label). Output port 1 (GetMultiBlockOutput): a vtkMultiBlockDataSet
 * with one vtkPolyData block per object, in the same order, named by its label in decimal
 * (vtkCompositeDataSet::NAME(), e.g. "2"), each with "vertex_state" and "object". One run fills
 * both ports.
 *
 * Every field of the library's BalloonParams has a Set/Get pair; NaN for ReferenceIntensity,
 * Tolerance and EdgeLengthMm means "estimate" (the default). Progress is reported through
 * UpdateProgress (ProgressEvent; the library's phase name as progress text), and setting
 * AbortExecute cancels the run. Any failure (no seed, unsupported scalars, cancelled,
 * leak, a label or region the library refuses, ...) is reported with vtkErrorMacro carrying the
 * library's message, and both outputs are empty.
 */
#ifndef vtkBalloonSegmentation_h
#define vtkBalloonSegmentation_h

#include "vtkBalloonSegmentationExport.h"
#include "vtkPolyDataAlgorithm.h"

#include <balloonseg.h>

#include <cmath>
#include <cstdint>
#include <vector>

class vtkMultiBlockDataSet;

/// Set<name>/Get<name> for the field `field` of the filter's BalloonParams: one line per
/// parameter, so the parameters live in one struct that is handed to the library as it is.
#define vtkBalloonParameterMacro(name, field, type)                                             \
  void Set##name(type value)                                                                   \
  {                                                                                            \
    if (!vtkBalloonSegmentation::SameValue(this->Params.field, value))                          \
    {                                                                                          \
      this->Params.field = value;                                                              \
      this->Modified();                                                                        \
    }                                                                                          \
  }                                                                                            \
  type Get##name() const { return this->Params.field; }

class VTKBALLOONSEGMENTATION_EXPORT vtkBalloonSegmentation : public vtkPolyDataAlgorithm
{
public:
  static vtkBalloonSegmentation* New();
  vtkTypeMacro(vtkBalloonSegmentation, vtkPolyDataAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /// Seeds in world coordinates. SetSeed replaces every seed by this one.
  void SetSeed(double x, double y, double z);
  void SetSeed(const double seed[3]) { this->SetSeed(seed[0], seed[1], seed[2]); }
  void AddSeed(double x, double y, double z);
  void AddSeed(const double seed[3]) { this->AddSeed(seed[0], seed[1], seed[2]); }
  void RemoveAllSeeds();
  int GetNumberOfSeeds() const { return static_cast<int>(this->Seeds.size() / 3); }
  /// Copies seed `index` into `seed`; returns false when there is no such seed.
  bool GetSeed(int index, double seed[3]) const;
  /// The label of seed `index` (1 for SetSeed/AddSeed seeds); 0 when there is no such seed.
  unsigned int GetSeedLabel(int index) const;
  ///@}

  ///@{
  /// A seed of object `label` (1 to 2^31 - 1; the library refuses 0 and larger ones with an
  /// error at execution). Seeds of one label grow as one object, its window from its first seed.
  void AddLabelledSeed(unsigned int label, double x, double y, double z);
  void AddLabelledSeed(unsigned int label, const double seed[3])
  {
    this->AddLabelledSeed(label, seed[0], seed[1], seed[2]);
  }
  /// The number of distinct labels among the seeds.
  int GetNumberOfObjects() const;
  ///@}

  ///@{
  /// Stop seeds (world mm): competitors that keep the objects out of their structure and are
  /// not in the output.
  void AddStopSeed(double x, double y, double z);
  void AddStopSeed(const double seed[3]) { this->AddStopSeed(seed[0], seed[1], seed[2]); }
  void RemoveAllStopSeeds();
  int GetNumberOfStopSeeds() const { return static_cast<int>(this->StopSeeds.size() / 3); }
  bool GetStopSeed(int index, double seed[3]) const;
  ///@}

  ///@{
  /// The region of interest as VTK bounds (xmin, xmax, ymin, ymax, zmin, zmax; world mm): no
  /// balloon grows beyond it. The library gets the corners (xmin, ymin, zmin) and (xmax, ymax,
  /// zmax). A flat or non-finite box, or a seed outside it, is an error at execution.
  void SetRegionOfInterest(double xmin, double xmax, double ymin, double ymax, double zmin,
    double zmax);
  void SetRegionOfInterest(const double bounds[6])
  {
    this->SetRegionOfInterest(bounds[0], bounds[1], bounds[2], bounds[3], bounds[4], bounds[5]);
  }
  void ClearRegionOfInterest();
  bool HasRegionOfInterest() const { return this->HasRegion; }
  /// Copies the bounds into `bounds`; returns false (bounds untouched) without a region.
  bool GetRegionOfInterest(double bounds[6]) const;
  ///@}

  ///@{
  /// Output port 1: one vtkPolyData block per object, named by its label.
  vtkMultiBlockDataSet* GetMultiBlockOutput();
  vtkAlgorithmOutput* GetMultiBlockOutputPort() { return this->GetOutputPort(1); }
  ///@}

  ///@{
  /// The library's BalloonParams, one Set/Get pair per field (the names: docs/interfaces.md,
  /// "Parameters"; the defaults from balloon_params_default). NaN for ReferenceIntensity,
  /// Tolerance and EdgeLengthMm = estimate (the default). A setter calls Modified() only when
  /// the value changes, and unlike vtkSetMacro takes NaN as equal to NaN.
  vtkBalloonParameterMacro(ReferenceIntensity, reference_intensity, double);
  vtkBalloonParameterMacro(Tolerance, tolerance, double);
  vtkBalloonParameterMacro(EdgeLengthMm, edge_length_mm, double);
  vtkBalloonParameterMacro(ElasticWeight, elastic_weight, double);
  vtkBalloonParameterMacro(BendingWeight, bending_weight, double);
  vtkBalloonParameterMacro(InflationWeight, inflation_weight, double);
  vtkBalloonParameterMacro(StepFraction, step_fraction, double);
  vtkBalloonParameterMacro(MaxIterations, max_iterations, unsigned int);
  vtkBalloonParameterMacro(SelfIntersectionInterval, self_intersection_interval, unsigned int);
  vtkBalloonParameterMacro(RefinementIterations, refinement_iterations, unsigned int);
  vtkBalloonParameterMacro(MaxReparametrizations, max_reparametrizations, unsigned int);
  vtkBalloonParameterMacro(MaxVertices, max_vertices, vtkTypeUInt64);
  vtkBalloonParameterMacro(Threads, threads, unsigned int); // 0 = all cores
  vtkBalloonParameterMacro(SimplifyErrorMm, simplify_error_mm, double); // 0 = not simplified
  ///@}

  ///@{
  /// SimplifyErrorMm under the name the issue and the docs give it: 0 (the default) returns the
  /// balloon as it is; a positive distance (mm) returns it simplified so that every point of
  /// the output lies within it of the balloon's surface and every point of that surface within
  /// it of the output (the two-sided Hausdorff distance), still closed, 2-manifold, outward and
  /// free of self-intersections (also between objects), with the same genus and components
  /// (several objects: each within the bound of its own balloon);
  /// "vertex_state" takes the least settled state of the vertices merged. A negative, NaN or
  /// infinite value is an error at execution, like any parameter out of range.
  void SetSimplificationError(double mm) { this->SetSimplifyErrorMm(mm); }
  double GetSimplificationError() const { return this->GetSimplifyErrorMm(); }
  ///@}

  ///@{
  /// Statistics of the last successful execution (the estimated reference intensity and
  /// tolerance, iterations, re-parametrisations, total seconds); with several objects, those of
  /// the first object's balloon.
  vtkGetMacro(LastReferenceIntensity, double);
  vtkGetMacro(LastTolerance, double);
  vtkGetMacro(LastIterations, unsigned int);
  vtkGetMacro(LastReparametrizations, unsigned int);
  vtkGetMacro(LastSeconds, double);
  ///@}

protected:
  vtkBalloonSegmentation();
  ~vtkBalloonSegmentation() override = default;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int FillOutputPortInformation(int port, vtkInformation* info) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  std::vector<double> Seeds;             // x, y, z per seed
  std::vector<unsigned int> SeedLabels; // one per seed
  std::vector<double> StopSeeds;         // x, y, z per stop seed
  bool HasRegion;
  double Region[6]; // VTK bounds

  BalloonParams Params;

  double LastReferenceIntensity;
  double LastTolerance;
  unsigned int LastIterations;
  unsigned int LastReparametrizations;
  double LastSeconds;

private:
  int SegmentOne(const BalloonVolume& volume, unsigned int label, vtkPolyData* output,
    vtkMultiBlockDataSet* blocks);
  void KeepStats(const BalloonStats& stats);
  static bool SameValue(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }
  template <typename T>
  static bool SameValue(T a, T b)
  {
    return a == b;
  }
  vtkBalloonSegmentation(const vtkBalloonSegmentation&) = delete;
  void operator=(const vtkBalloonSegmentation&) = delete;
};

#endif
