import { render, screen, within } from '@testing-library/react';
import { afterEach, describe, expect, it, vi } from 'vitest';
import { CameraView } from './CameraView';

const DETECTIONS = {
  ts: 1,
  mode: 'warm',
  scene: 'The kitchen counter. In view: a red mug and a green bottle.',
  scene_age_s: 6.4,
  detections: [{ label: 'red mug', score: 0.93, skill: 'find_object', age_s: 0.4, stale: false }],
};

afterEach(() => vi.unstubAllGlobals());

describe('camera panel', () => {
  it('shows the scene description as text beside the image, not on it', async () => {
    vi.stubGlobal('URL', { ...URL, createObjectURL: () => 'blob:frame', revokeObjectURL: () => undefined });
    vi.stubGlobal(
      'fetch',
      vi.fn(async (url: string) =>
        url.endsWith('/detections')
          ? new Response(JSON.stringify(DETECTIONS), { status: 200 })
          : new Response(new Blob([new Uint8Array([1, 2, 3])], { type: 'image/jpeg' }), { status: 200 }),
      ),
    );
    render(<CameraView />);
    const panel = screen.getByRole('region', { name: 'Camera view' });
    const scene = await within(panel).findByLabelText('Scene description');
    expect(scene).toHaveTextContent('The kitchen counter. In view: a red mug and a green bottle. · 6 s ago');
    expect(await within(panel).findByRole('img', { name: 'Camera' })).toHaveAttribute('src', 'blob:frame');
    expect(within(panel).getByText('red mug')).toBeInTheDocument();
  });
});
