// vtkBalloonSegmentation: a vtkPolyDataAlgorithm around the balloonseg C ABI (balloonseg.h).
// The image's scalars are borrowed (pointer + strides in elements), never copied; the mesh the
// library returns is copied once into the output vtkPolyData.
#include "vtkBalloonSegmentation.h"

#include "vtkCellArray.h"
#include "vtkDataArray.h"
#include "vtkDataObject.h"
#include "vtkDataSetAttributes.h"
#include "vtkDoubleArray.h"
#include "vtkIdTypeArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkMatrix3x3.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkUnsignedCharArray.h"

#include <balloonseg.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <memory>
#include <string>

vtkStandardNewMacro(vtkBalloonSegmentation);

namespace
{
struct SegmenterDeleter
{
  void operator()(BalloonSegmenter* s) const { balloon_free(s); }
};
using SegmenterPtr = std::unique_ptr<BalloonSegmenter, SegmenterDeleter>;

// VTK scalar type -> BalloonScalarType; false for types the library does not take.
bool ToBalloonScalarType(int vtkType, uint32_t* out)
{
  switch (vtkType)
  {
    case VTK_UNSIGNED_CHAR:
      *out = BALLOON_SCALAR_U8;
      return true;
    case VTK_CHAR: // VTK treats char as signed 8-bit data
    case VTK_SIGNED_CHAR:
      *out = BALLOON_SCALAR_I8;
      return true;
    case VTK_UNSIGNED_SHORT:
      *out = BALLOON_SCALAR_U16;
      return true;
    case VTK_SHORT:
      *out = BALLOON_SCALAR_I16;
      return true;
    case VTK_UNSIGNED_INT:
      *out = BALLOON_SCALAR_U32;
      return true;
    case VTK_INT:
      *out = BALLOON_SCALAR_I32;
      return true;
    case VTK_FLOAT:
      *out = BALLOON_SCALAR_F32;
      return true;
    case VTK_DOUBLE:
      *out = BALLOON_SCALAR_F64;
      return true;
    default:
      return false;
  }
}

// "what: STATUS: the library's message".
/// A BalloonParams field's name as the filter's Set/Get spell it: edge_length_mm -> EdgeLengthMm.
std::string CamelCase(const char* field)
{
  std::string name;
  bool upper = true;
  for (const char* c = field; *c; ++c)
  {
    if (*c == '_')
    {
      upper = true;
      continue;
    }
    name += upper ? static_cast<char>(std::toupper(static_cast<unsigned char>(*c))) : *c;
    upper = false;
  }
  return name;
}

std::string FailureMessage(const char* what, BalloonStatus status)
{
  std::string message = std::string(what) + ": " + balloon_status_string(status);
  const size_t length = balloon_last_error_message(nullptr, 0);
  if (length > 0)
  {
    std::string detail(length + 1, '\0');
    balloon_last_error_message(&detail[0], detail.size());
    detail.resize(length);
    message += ": " + detail;
  }
  return message;
}

// The library's progress callback. Observers of ProgressEvent run inside it: an exception
// from one must not unwind into the library, so it cancels the run instead.
int ReportProgress(double fraction, const char* phase, void* userData)
{
  auto* self = static_cast<vtkBalloonSegmentation*>(userData);
  try
  {
    self->SetProgressText(phase);
    self->UpdateProgress(fraction);
  }
  catch (...)
  {
    self->SetAbortExecute(1);
  }
  return self->GetAbortExecute() ? 1 : 0;
}
}

vtkBalloonSegmentation::vtkBalloonSegmentation()
  : LastReferenceIntensity(std::nan(""))
  , LastTolerance(std::nan(""))
  , LastIterations(0)
  , LastReparametrizations(0)
  , LastSeconds(0.0)
{
  // Fails only on a NULL pointer.
  balloon_params_default(&this->Params);
  this->SetInputArrayToProcess(0, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS,
    vtkDataSetAttributes::SCALARS);
}

void vtkBalloonSegmentation::SetSeed(double x, double y, double z)
{
  if (this->Seeds.size() == 3 && this->Seeds[0] == x && this->Seeds[1] == y &&
    this->Seeds[2] == z)
  {
    return;
  }
  this->Seeds.assign({ x, y, z });
  this->Modified();
}

void vtkBalloonSegmentation::AddSeed(double x, double y, double z)
{
  this->Seeds.insert(this->Seeds.end(), { x, y, z });
  this->Modified();
}

void vtkBalloonSegmentation::RemoveAllSeeds()
{
  if (!this->Seeds.empty())
  {
    this->Seeds.clear();
    this->Modified();
  }
}

bool vtkBalloonSegmentation::GetSeed(int index, double seed[3]) const
{
  if (index < 0 || index >= this->GetNumberOfSeeds())
  {
    return false;
  }
  for (int c = 0; c < 3; ++c)
  {
    seed[c] = this->Seeds[3 * index + c];
  }
  return true;
}

int vtkBalloonSegmentation::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

int vtkBalloonSegmentation::RequestUpdateExtent(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector*)
{
  // The balloon may grow anywhere in the image: always ask for all of it.
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(),
    inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()), 6);
  return 1;
}

int vtkBalloonSegmentation::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkImageData* input = vtkImageData::GetData(inputVector[0]);
  vtkPolyData* output = vtkPolyData::GetData(outputVector);
  output->Initialize();
  if (!input || !output)
  {
    vtkErrorMacro(<< "the input must be a vtkImageData");
    return 0;
  }
  if (this->Seeds.empty())
  {
    vtkErrorMacro(<< "no seed: call SetSeed(x, y, z) with a world point inside the structure");
    return 0;
  }
  vtkDataArray* scalars = this->GetInputArrayToProcess(0, inputVector);
  if (!scalars)
  {
    vtkErrorMacro(<< "the image has no point scalars to segment");
    return 0;
  }

  BalloonVolume volume;
  if (!ToBalloonScalarType(scalars->GetDataType(), &volume.scalar_type))
  {
    vtkErrorMacro(<< "scalar type " << scalars->GetDataTypeAsString()
                  << " is not supported: convert the image (vtkImageCast) to unsigned/signed "
                     "char, (unsigned) short, (unsigned) int, float or double");
    return 0;
  }
  int extent[6];
  input->GetExtent(extent);
  vtkIdType dims[3];
  for (int a = 0; a < 3; ++a)
  {
    dims[a] = static_cast<vtkIdType>(extent[2 * a + 1]) - extent[2 * a] + 1;
    if (dims[a] <= 0)
    {
      vtkErrorMacro(<< "the image is empty (extent " << extent[0] << " " << extent[1] << " "
                    << extent[2] << " " << extent[3] << " " << extent[4] << " " << extent[5]
                    << ")");
      return 0;
    }
  }
  if (scalars->GetNumberOfTuples() != dims[0] * dims[1] * dims[2])
  {
    vtkErrorMacro(<< "the scalars have " << scalars->GetNumberOfTuples()
                  << " tuples but the extent has " << dims[0] * dims[1] * dims[2] << " points");
    return 0;
  }

  // Point data of a vtkImageData is stored x fastest over its extent, components interleaved:
  // the first component of the extent's first voxel, strides in elements.
  const vtkIdType components = scalars->GetNumberOfComponents();
  volume.data = scalars->GetVoidPointer(0);
  volume.strides[0] = static_cast<ptrdiff_t>(components);
  volume.strides[1] = static_cast<ptrdiff_t>(components * dims[0]);
  volume.strides[2] = static_cast<ptrdiff_t>(components * dims[0] * dims[1]);
  for (int a = 0; a < 3; ++a)
  {
    volume.dims[a] = static_cast<size_t>(dims[a]);
    volume.spacing[a] = input->GetSpacing()[a];
  }
  input->TransformIndexToPhysicalPoint(extent[0], extent[2], extent[4], volume.origin);
  const double* direction = input->GetDirectionMatrix()->GetData(); // row-major
  for (int e = 0; e < 9; ++e)
  {
    volume.direction[e] = direction[e];
  }

  BalloonSegmenter* raw = nullptr;
  BalloonStatus status = balloon_init(&volume, &this->Params, this->Seeds.data(), &raw);
  SegmenterPtr segmenter(raw);
  if (status != BALLOON_OK)
  {
    vtkErrorMacro(<< FailureMessage("balloon_init", status));
    return 0;
  }
  for (size_t s = 3; s < this->Seeds.size(); s += 3)
  {
    status = balloon_add_seed(segmenter.get(), &this->Seeds[s]);
    if (status != BALLOON_OK)
    {
      vtkErrorMacro(<< FailureMessage("balloon_add_seed", status));
      return 0;
    }
  }
  balloon_set_progress_callback(segmenter.get(), &ReportProgress, this);
  status = balloon_segment(segmenter.get());
  if (status == BALLOON_CANCELLED)
  {
    vtkErrorMacro(<< "segmentation cancelled (AbortExecute)");
    return 0;
  }
  if (status != BALLOON_OK)
  {
    vtkErrorMacro(<< FailureMessage("balloon_segment", status));
    return 0;
  }

  BalloonMesh mesh;
  status = balloon_mesh(segmenter.get(), &mesh);
  if (status != BALLOON_OK)
  {
    vtkErrorMacro(<< FailureMessage("balloon_mesh", status));
    return 0;
  }
  const vtkIdType pointCount = static_cast<vtkIdType>(mesh.point_count);
  const vtkIdType triangleCount = static_cast<vtkIdType>(mesh.triangle_count);

  vtkNew<vtkDoubleArray> coordinates;
  coordinates->SetNumberOfComponents(3);
  coordinates->SetNumberOfTuples(pointCount);
  std::copy(mesh.points, mesh.points + 3 * pointCount, coordinates->GetPointer(0));
  vtkNew<vtkPoints> points;
  points->SetData(coordinates);

  vtkNew<vtkIdTypeArray> offsets;
  offsets->SetNumberOfValues(triangleCount + 1);
  vtkNew<vtkIdTypeArray> connectivity;
  connectivity->SetNumberOfValues(3 * triangleCount);
  for (vtkIdType t = 0; t <= triangleCount; ++t)
  {
    offsets->SetValue(t, 3 * t);
  }
  for (vtkIdType c = 0; c < 3 * triangleCount; ++c)
  {
    connectivity->SetValue(c, static_cast<vtkIdType>(mesh.triangles[c]));
  }
  vtkNew<vtkCellArray> triangles;
  triangles->SetData(offsets, connectivity);

  vtkNew<vtkUnsignedCharArray> state;
  state->SetName("vertex_state");
  state->SetNumberOfValues(pointCount);
  if (mesh.vertex_state)
  {
    std::copy(mesh.vertex_state, mesh.vertex_state + pointCount, state->GetPointer(0));
  }
  else
  {
    state->FillValue(BALLOON_VERTEX_MOVING);
  }

  output->SetPoints(points);
  output->SetPolys(triangles);
  output->GetPointData()->AddArray(state);

  BalloonStats stats;
  stats.struct_size = sizeof(BalloonStats);
  if (balloon_stats(segmenter.get(), &stats) == BALLOON_OK)
  {
    this->LastReferenceIntensity = stats.reference_intensity;
    this->LastTolerance = stats.tolerance;
    this->LastIterations = stats.iterations;
    this->LastReparametrizations = stats.reparametrizations;
    this->LastSeconds = stats.seconds_total;
  }
  return 1;
}

void vtkBalloonSegmentation::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Seeds (" << this->GetNumberOfSeeds() << "):";
  for (size_t s = 0; s < this->Seeds.size(); s += 3)
  {
    os << " (" << this->Seeds[s] << ", " << this->Seeds[s + 1] << ", " << this->Seeds[s + 2]
       << ")";
  }
  os << "\n";
  // The parameters as the library's table names them, so a new one prints without an edit here.
  for (size_t i = 0; i < balloon_param_count(); ++i)
  {
    BalloonParamInfo info{};
    info.struct_size = sizeof info;
    double value = 0;
    if (balloon_param_info(i, &info) == BALLOON_OK &&
      balloon_params_get(&this->Params, info.name, &value) == BALLOON_OK)
    {
      os << indent << CamelCase(info.name) << ": ";
      if (info.kind == BALLOON_PARAM_INTEGER)
      {
        os << static_cast<vtkTypeUInt64>(value) << "\n";
      }
      else
      {
        os << value << "\n";
      }
    }
  }
  os << indent << "LastReferenceIntensity: " << this->LastReferenceIntensity << "\n";
  os << indent << "LastTolerance: " << this->LastTolerance << "\n";
  os << indent << "LastIterations: " << this->LastIterations << "\n";
  os << indent << "LastReparametrizations: " << this->LastReparametrizations << "\n";
  os << indent << "LastSeconds: " << this->LastSeconds << "\n";
}
