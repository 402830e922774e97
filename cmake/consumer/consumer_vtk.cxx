// Uses the installed VTK filter in a pipeline: a bright ball in a dark image, one seed at its
// centre; the result must be a non-empty closed mesh around the seed.
#include <balloonseg.h>
#include <vtkBalloonSegmentation.h>

#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPolyData.h>
#include <vtkUnsignedCharArray.h>
#include <vtkPointData.h>

#include <cstdio>

int main()
{
  vtkNew<vtkImageData> image;
  image->SetDimensions(32, 32, 32);
  image->SetSpacing(0.8, 0.8, 1.2);
  image->SetOrigin(-12.4, -12.4, -18.6);
  image->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  auto* voxels = static_cast<unsigned char*>(image->GetScalarPointer());
  for (int k = 0; k < 32; ++k)
    for (int j = 0; j < 32; ++j)
      for (int i = 0; i < 32; ++i)
      {
        double p[3];
        image->TransformIndexToPhysicalPoint(i, j, k, p);
        voxels[(k * 32 + j) * 32 + i] = p[0] * p[0] + p[1] * p[1] + p[2] * p[2] < 64.0 ? 200 : 20;
      }

  vtkNew<vtkBalloonSegmentation> balloon;
  balloon->SetInputData(image);
  balloon->SetSeed(0.0, 0.0, 0.0);
  balloon->SetThreads(1);
  balloon->Update();
  vtkPolyData* mesh = balloon->GetOutput();
  double bounds[6];
  mesh->GetBounds(bounds);
  std::printf("balloonseg %s + vtkBalloonSegmentation: %lld points, %lld triangles, "
              "x %.2f..%.2f\n",
    balloon_version(), static_cast<long long>(mesh->GetNumberOfPoints()),
    static_cast<long long>(mesh->GetNumberOfPolys()), bounds[0], bounds[1]);
  const bool ok = mesh->GetNumberOfPolys() > 0 && bounds[0] < -6.0 && bounds[1] > 6.0 &&
    mesh->GetPointData()->GetArray("vertex_state") != nullptr;
  return ok ? 0 : 1;
}
