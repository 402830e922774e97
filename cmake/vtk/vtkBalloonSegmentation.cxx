// vtkBalloonSegmentation: a vtkPolyDataAlgorithm around the balloonseg C ABI (balloonseg.h).
// The image's scalars are borrowed (pointer + strides in elements), never copied; the mesh the
// library returns is copied once into the output vtkPolyData.
#include "vtkBalloonSegmentation.h"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkCompositeDataSet.h"
#include "vtkDataArray.h"
#include "vtkDataObject.h"
#include "vtkDataSetAttributes.h"
#include "vtkDoubleArray.h"
#include "vtkIdTypeArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkMatrix3x3.h"
#include "vtkMultiBlockDataSet.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkSmartPointer.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkUnsignedCharArray.h"

#include <balloonseg.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <memory>
#include <string>
#include <utility>

vtkStandardNewMacro(vtkBalloonSegmentation);

namespace
{
struct SegmenterDeleter
{
  void operator()(BalloonSegmenter* s) const { balloon_free(s); }
};
using SegmenterPtr = std::unique_ptr<BalloonSegmenter, SegmenterDeleter>;
struct ObjectsDeleter
{
  void operator()(BalloonObjects* o) const { balloon_objects_free(o); }
};
using ObjectsPtr = std::unique_ptr<BalloonObjects, ObjectsDeleter>;

// One object's mesh (a view the library owns) copied into a new vtkPolyData: double points,
// triangles, "vertex_state" point data and the Int32 "object" cell array (all `label`).
vtkSmartPointer<vtkPolyData> ToPolyData(const BalloonMesh& mesh, unsigned int label)
{
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

  vtkNew<vtkIntArray> object;
  object->SetName("object");
  object->SetNumberOfValues(triangleCount);
  object->FillValue(static_cast<int>(label));

  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetPolys(triangles);
  poly->GetPointData()->AddArray(state);
  poly->GetCellData()->AddArray(object);
  return poly;
}

// An object of the result: its label and a view of its mesh (owned by the library's handle).
struct ObjectView
{
  unsigned int label;
  BalloonMesh mesh;
};

// The objects one after the other in one vtkPolyData (point ids shifted, arrays appended); one
// object is exactly ToPolyData's.
void AppendObjects(const std::vector<ObjectView>& objects, vtkPolyData* output)
{
  if (objects.size() == 1)
  {
    output->ShallowCopy(ToPolyData(objects[0].mesh, objects[0].label));
    return;
  }
  vtkIdType pointCount = 0, triangleCount = 0;
  for (const ObjectView& o : objects)
  {
    pointCount += static_cast<vtkIdType>(o.mesh.point_count);
    triangleCount += static_cast<vtkIdType>(o.mesh.triangle_count);
  }
  vtkNew<vtkDoubleArray> coordinates;
  coordinates->SetNumberOfComponents(3);
  coordinates->SetNumberOfTuples(pointCount);
  vtkNew<vtkUnsignedCharArray> state;
  state->SetName("vertex_state");
  state->SetNumberOfValues(pointCount);
  vtkNew<vtkIdTypeArray> offsets;
  offsets->SetNumberOfValues(triangleCount + 1);
  vtkNew<vtkIdTypeArray> connectivity;
  connectivity->SetNumberOfValues(3 * triangleCount);
  vtkNew<vtkIntArray> object;
  object->SetName("object");
  object->SetNumberOfValues(triangleCount);
  vtkIdType firstPoint = 0, firstTriangle = 0;
  for (const ObjectView& o : objects)
  {
    const vtkIdType n = static_cast<vtkIdType>(o.mesh.point_count);
    const vtkIdType m = static_cast<vtkIdType>(o.mesh.triangle_count);
    std::copy(o.mesh.points, o.mesh.points + 3 * n, coordinates->GetPointer(3 * firstPoint));
    if (o.mesh.vertex_state)
    {
      std::copy(o.mesh.vertex_state, o.mesh.vertex_state + n, state->GetPointer(firstPoint));
    }
    else
    {
      std::fill(state->GetPointer(firstPoint), state->GetPointer(firstPoint) + n,
        static_cast<unsigned char>(BALLOON_VERTEX_MOVING));
    }
    for (vtkIdType c = 0; c < 3 * m; ++c)
    {
      connectivity->SetValue(
        3 * firstTriangle + c, static_cast<vtkIdType>(o.mesh.triangles[c]) + firstPoint);
    }
    for (vtkIdType t = 0; t < m; ++t)
    {
      object->SetValue(firstTriangle + t, static_cast<int>(o.label));
    }
    firstPoint += n;
    firstTriangle += m;
  }
  for (vtkIdType t = 0; t <= triangleCount; ++t)
  {
    offsets->SetValue(t, 3 * t);
  }
  vtkNew<vtkPoints> points;
  points->SetData(coordinates);
  vtkNew<vtkCellArray> triangles;
  triangles->SetData(offsets, connectivity);
  output->SetPoints(points);
  output->SetPolys(triangles);
  output->GetPointData()->AddArray(state);
  output->GetCellData()->AddArray(object);
}

// Both outputs from the objects' views: port 0 all of them, port 1 one block per object.
void FillOutputs(const std::vector<ObjectView>& objects, vtkPolyData* output,
  vtkMultiBlockDataSet* blocks)
{
  AppendObjects(objects, output);
  if (!blocks)
  {
    return;
  }
  blocks->SetNumberOfBlocks(static_cast<unsigned int>(objects.size()));
  for (size_t b = 0; b < objects.size(); ++b)
  {
    const unsigned int block = static_cast<unsigned int>(b);
    blocks->SetBlock(block, ToPolyData(objects[b].mesh, objects[b].label));
    blocks->GetMetaData(block)->Set(
      vtkCompositeDataSet::NAME(), std::to_string(objects[b].label).c_str());
  }
}

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
  this->HasRegion = false;
  std::fill(this->Region, this->Region + 6, 0.0);
  this->SetNumberOfOutputPorts(2);
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
  this->SeedLabels.assign(1, 1u);
  this->Modified();
}

void vtkBalloonSegmentation::AddSeed(double x, double y, double z)
{
  this->AddLabelledSeed(1u, x, y, z);
}

void vtkBalloonSegmentation::AddLabelledSeed(unsigned int label, double x, double y, double z)
{
  this->Seeds.insert(this->Seeds.end(), { x, y, z });
  this->SeedLabels.push_back(label);
  this->Modified();
}

unsigned int vtkBalloonSegmentation::GetSeedLabel(int index) const
{
  if (index < 0 || index >= this->GetNumberOfSeeds())
  {
    return 0;
  }
  return this->SeedLabels[index];
}

int vtkBalloonSegmentation::GetNumberOfObjects() const
{
  std::vector<unsigned int> labels(this->SeedLabels);
  std::sort(labels.begin(), labels.end());
  return static_cast<int>(std::unique(labels.begin(), labels.end()) - labels.begin());
}

void vtkBalloonSegmentation::AddStopSeed(double x, double y, double z)
{
  this->StopSeeds.insert(this->StopSeeds.end(), { x, y, z });
  this->Modified();
}

void vtkBalloonSegmentation::RemoveAllStopSeeds()
{
  if (!this->StopSeeds.empty())
  {
    this->StopSeeds.clear();
    this->Modified();
  }
}

bool vtkBalloonSegmentation::GetStopSeed(int index, double seed[3]) const
{
  if (index < 0 || index >= this->GetNumberOfStopSeeds())
  {
    return false;
  }
  std::copy(&this->StopSeeds[3 * index], &this->StopSeeds[3 * index] + 3, seed);
  return true;
}

void vtkBalloonSegmentation::SetRegionOfInterest(
  double xmin, double xmax, double ymin, double ymax, double zmin, double zmax)
{
  const double bounds[6] = { xmin, xmax, ymin, ymax, zmin, zmax };
  if (this->HasRegion && std::equal(bounds, bounds + 6, this->Region))
  {
    return;
  }
  std::copy(bounds, bounds + 6, this->Region);
  this->HasRegion = true;
  this->Modified();
}

void vtkBalloonSegmentation::ClearRegionOfInterest()
{
  if (this->HasRegion)
  {
    this->HasRegion = false;
    this->Modified();
  }
}

bool vtkBalloonSegmentation::GetRegionOfInterest(double bounds[6]) const
{
  if (!this->HasRegion)
  {
    return false;
  }
  std::copy(this->Region, this->Region + 6, bounds);
  return true;
}

vtkMultiBlockDataSet* vtkBalloonSegmentation::GetMultiBlockOutput()
{
  return vtkMultiBlockDataSet::SafeDownCast(this->GetOutputDataObject(1));
}

void vtkBalloonSegmentation::RemoveAllSeeds()
{
  if (!this->Seeds.empty())
  {
    this->Seeds.clear();
    this->SeedLabels.clear();
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

int vtkBalloonSegmentation::FillOutputPortInformation(int port, vtkInformation* info)
{
  if (port == 1)
  {
    info->Set(vtkDataObject::DATA_TYPE_NAME(), "vtkMultiBlockDataSet");
    return 1;
  }
  return this->Superclass::FillOutputPortInformation(port, info);
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
  vtkPolyData* output = vtkPolyData::GetData(outputVector, 0);
  vtkMultiBlockDataSet* blocks = vtkMultiBlockDataSet::GetData(outputVector, 1);
  if (output)
  {
    output->Initialize();
  }
  if (blocks)
  {
    blocks->Initialize();
  }
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

  // The objects in the order their labels first appear, each with its seeds.
  std::vector<std::pair<unsigned int, std::vector<double>>> objects;
  for (size_t s = 0; s < this->SeedLabels.size(); ++s)
  {
    const unsigned int label = this->SeedLabels[s];
    auto it = std::find_if(objects.begin(), objects.end(),
      [label](const std::pair<unsigned int, std::vector<double>>& o) { return o.first == label; });
    if (it == objects.end())
    {
      objects.emplace_back(label, std::vector<double>());
      it = objects.end() - 1;
    }
    it->second.insert(it->second.end(), &this->Seeds[3 * s], &this->Seeds[3 * s] + 3);
  }
  // One object alone is the single balloon, as before (a label the library would refuse goes
  // to balloon_segment_objects, which says so).
  if (objects.size() == 1 && this->StopSeeds.empty() && !this->HasRegion &&
    objects[0].first >= 1 && objects[0].first <= 2147483647u)
  {
    return this->SegmentOne(volume, objects[0].first, output, blocks);
  }

  std::vector<BalloonObjectSeeds> request(objects.size());
  for (size_t o = 0; o < objects.size(); ++o)
  {
    request[o].label = objects[o].first;
    request[o].points = objects[o].second.data();
    request[o].point_count = objects[o].second.size() / 3;
  }
  // VTK bounds -> the library's two opposite corners (xmin, ymin, zmin), (xmax, ymax, zmax).
  const double* r = this->Region;
  const double corners[6] = { r[0], r[2], r[4], r[1], r[3], r[5] };
  BalloonObjects* raw = nullptr;
  BalloonStatus status = balloon_segment_objects(&volume, &this->Params, request.data(),
    request.size(), this->StopSeeds.empty() ? nullptr : this->StopSeeds.data(),
    this->StopSeeds.size() / 3, this->HasRegion ? corners : nullptr, &ReportProgress, this, &raw);
  ObjectsPtr result(raw);
  if (status == BALLOON_CANCELLED)
  {
    vtkErrorMacro(<< "segmentation cancelled (AbortExecute)");
    return 0;
  }
  if (status != BALLOON_OK)
  {
    vtkErrorMacro(<< FailureMessage("balloon_segment_objects", status));
    return 0;
  }
  size_t count = 0;
  status = balloon_objects_count(result.get(), &count);
  std::vector<ObjectView> views(count);
  for (size_t o = 0; o < count && status == BALLOON_OK; ++o)
  {
    status = balloon_objects_label(result.get(), o, &views[o].label);
    if (status == BALLOON_OK)
    {
      status = balloon_objects_mesh(result.get(), o, &views[o].mesh);
    }
  }
  if (status != BALLOON_OK)
  {
    vtkErrorMacro(<< FailureMessage("balloon_objects_mesh", status));
    return 0;
  }
  FillOutputs(views, output, blocks);

  BalloonStats stats;
  stats.struct_size = sizeof(BalloonStats);
  if (count > 0 && balloon_objects_stats(result.get(), 0, &stats) == BALLOON_OK)
  {
    this->KeepStats(stats);
  }
  return 1;
}

int vtkBalloonSegmentation::SegmentOne(
  const BalloonVolume& volume, unsigned int label, vtkPolyData* output, vtkMultiBlockDataSet* blocks)
{
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

  std::vector<ObjectView> views(1);
  views[0].label = label;
  status = balloon_mesh(segmenter.get(), &views[0].mesh);
  if (status != BALLOON_OK)
  {
    vtkErrorMacro(<< FailureMessage("balloon_mesh", status));
    return 0;
  }
  FillOutputs(views, output, blocks);

  BalloonStats stats;
  stats.struct_size = sizeof(BalloonStats);
  if (balloon_stats(segmenter.get(), &stats) == BALLOON_OK)
  {
    this->KeepStats(stats);
  }
  return 1;
}

void vtkBalloonSegmentation::KeepStats(const BalloonStats& stats)
{
  this->LastReferenceIntensity = stats.reference_intensity;
  this->LastTolerance = stats.tolerance;
  this->LastIterations = stats.iterations;
  this->LastReparametrizations = stats.reparametrizations;
  this->LastSeconds = stats.seconds_total;
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
  os << indent << "Seed labels:";
  for (unsigned int label : this->SeedLabels)
  {
    os << " " << label;
  }
  os << "\n";
  os << indent << "Stop seeds (" << this->GetNumberOfStopSeeds() << "):";
  for (size_t s = 0; s < this->StopSeeds.size(); s += 3)
  {
    os << " (" << this->StopSeeds[s] << ", " << this->StopSeeds[s + 1] << ", "
       << this->StopSeeds[s + 2] << ")";
  }
  os << "\n";
  os << indent << "RegionOfInterest: ";
  if (this->HasRegion)
  {
    os << "(" << this->Region[0] << ", " << this->Region[1] << ", " << this->Region[2] << ", "
       << this->Region[3] << ", " << this->Region[4] << ", " << this->Region[5] << ")\n";
  }
  else
  {
    os << "(none)\n";
  }
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
