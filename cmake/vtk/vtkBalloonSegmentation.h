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
 * required). Every field of the library's BalloonParams has a Set/Get pair; NaN for
 * ReferenceIntensity, Tolerance and EdgeLengthMm means "estimate" (the default). Progress is
 * reported through UpdateProgress (ProgressEvent; the library's phase name as progress text),
 * and setting AbortExecute cancels the run. Any failure (no seed, unsupported scalars, cancelled,
 * leak, ...) is reported with vtkErrorMacro carrying the library's message, and the output is
 * empty.
 */
#ifndef vtkBalloonSegmentation_h
#define vtkBalloonSegmentation_h

#include "vtkBalloonSegmentationExport.h"
#include "vtkPolyDataAlgorithm.h"

#include <cstdint>
#include <vector>

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
  ///@}

  ///@{
  /// The library's BalloonParams, one field each (defaults from balloon_params_default).
  /// NaN = estimate (the default). Setting NaN again does not call Modified(): unlike
  /// vtkSetMacro, these setters treat NaN as equal to NaN.
  void SetReferenceIntensity(double value);
  vtkGetMacro(ReferenceIntensity, double);
  void SetTolerance(double value);
  vtkGetMacro(Tolerance, double);
  void SetEdgeLengthMm(double value);
  vtkGetMacro(EdgeLengthMm, double);
  vtkSetMacro(ElasticWeight, double);
  vtkGetMacro(ElasticWeight, double);
  vtkSetMacro(BendingWeight, double);
  vtkGetMacro(BendingWeight, double);
  vtkSetMacro(InflationWeight, double);
  vtkGetMacro(InflationWeight, double);
  vtkSetMacro(StepFraction, double);
  vtkGetMacro(StepFraction, double);
  vtkSetMacro(MaxIterations, unsigned int);
  vtkGetMacro(MaxIterations, unsigned int);
  vtkSetMacro(SelfIntersectionInterval, unsigned int);
  vtkGetMacro(SelfIntersectionInterval, unsigned int);
  vtkSetMacro(RefinementIterations, unsigned int);
  vtkGetMacro(RefinementIterations, unsigned int);
  vtkSetMacro(MaxReparametrizations, unsigned int);
  vtkGetMacro(MaxReparametrizations, unsigned int);
  vtkSetMacro(MaxVertices, vtkTypeUInt64);
  vtkGetMacro(MaxVertices, vtkTypeUInt64);
  /// 0 = all cores.
  vtkSetMacro(Threads, unsigned int);
  vtkGetMacro(Threads, unsigned int);
  ///@}

  ///@{
  /// Statistics of the last successful execution (the estimated reference intensity and
  /// tolerance, iterations, re-parametrisations, total seconds).
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
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  std::vector<double> Seeds; // x, y, z per seed

  double ReferenceIntensity;
  double Tolerance;
  double EdgeLengthMm;
  double ElasticWeight;
  double BendingWeight;
  double InflationWeight;
  double StepFraction;
  unsigned int MaxIterations;
  unsigned int SelfIntersectionInterval;
  unsigned int RefinementIterations;
  unsigned int MaxReparametrizations;
  vtkTypeUInt64 MaxVertices;
  unsigned int Threads;

  double LastReferenceIntensity;
  double LastTolerance;
  unsigned int LastIterations;
  unsigned int LastReparametrizations;
  double LastSeconds;

private:
  void SetEstimable(double& field, double value);
  vtkBalloonSegmentation(const vtkBalloonSegmentation&) = delete;
  void operator=(const vtkBalloonSegmentation&) = delete;
};

#endif
