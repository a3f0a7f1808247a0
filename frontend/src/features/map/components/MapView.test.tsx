import { render, screen, waitFor, within } from '@testing-library/react';
import userEvent from '@testing-library/user-event';
import { afterEach, describe, expect, it, vi } from 'vitest';
import { localClock, type Sighting } from '@/features/history/api/history';
import { useChatStore } from '@/stores/chatStore';
import { useHistoryStore } from '@/stores/historyStore';
import { MapView } from './MapView';

const LOCATIONS = {
  map: 'office',
  locations: [
    { name: 'dock', label: 'Charging dock', description: '', x: 0, y: 0 },
    { name: 'kitchen', label: 'Kitchen', description: '', x: 6, y: 4 },
    { name: 'mailroom', label: 'Mailroom', description: '', x: 9, y: -3 },
  ],
};
const POSE = { x: 0, y: 0, theta: 0, at_location: 'dock', moving: false, destination: null };
const DRIVING = { ...POSE, x: 2, y: 1, at_location: null, moving: true, destination: 'mailroom' };
// a 1×1 white PNG: the masks' content is the browser's business
const PIXEL = 'iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAAAAAA6fptVAAAACklEQVR4nGP4DwABAQEAG7buVgAAAABJRU5ErkJggg==';
const FLOOR = {
  available: true,
  resolution: 0.5,
  origin: { x: -1, y: -4 },
  width: 24,
  height: 20,
  bounds: { x0: -1, y0: -4, x1: 11, y1: 6 },
  walls_png: PIXEL,
  unknown_png: PIXEL,
  blocked: [{ x0: 7, y0: -3.5, x1: 7.2, y1: -2.5 }],
  version: 'v1',
};
const PLAN = { frame: 'map', points: [[2, 1], [5, 5], [9, -3]], destination: 'mailroom' };
const parcel: Sighting = {
  id: 's-2',
  label: 'yellow package',
  skill: 'find_object',
  first_seen: '2026-11-24T14:03:12.000Z',
  last_seen: null,
  ago: '2 min ago',
  t: null,
  seen_for: null,
  place: 'mailroom',
  pose: { x: 8.5, y: -2.5, yaw: 1.2, map: 'office' },
  score: 0.9,
  count: 3,
};

function serveMap(pose: object = POSE, floor: object = { available: false }) {
  const answers: Record<string, object> = { locations: LOCATIONS, pose, floor, plan: PLAN };
  vi.stubGlobal(
    'fetch',
    vi.fn(async (url: string) => new Response(JSON.stringify(answers[url.split('/').pop() ?? ''] ?? {}), { status: 200 })),
  );
}

afterEach(() => {
  vi.unstubAllGlobals();
  useHistoryStore.setState({ selected: null });
});

describe('map: where the robot was when it saw something', () => {
  it('marks the chosen sighting next to the live robot, and Clear removes only that marker', async () => {
    serveMap();
    useHistoryStore.setState({ selected: parcel });
    render(<MapView />);
    const map = screen.getByRole('region', { name: 'Map' });
    const marker = await within(map).findByTestId('history-marker');
    expect(marker).toHaveAttribute('data-x', '8.5');
    expect(marker).toHaveAttribute('data-y', '-2.5');
    expect(marker).toHaveAccessibleName(`Robot was here at ${localClock(parcel.first_seen)} when it saw yellow package (mailroom)`);
    expect(marker).toHaveTextContent(`yellow package · ${localClock(parcel.first_seen)}`);
    expect(within(marker).getByTestId('history-heading')).toBeInTheDocument();
    expect(within(map).getByTestId('robot')).toHaveAttribute('data-x', '0');

    await userEvent.click(within(map).getByRole('button', { name: 'Clear history marker' }));
    expect(within(map).queryByTestId('history-marker')).toBeNull();
    expect(within(map).getByTestId('robot')).toBeInTheDocument();
    expect(useHistoryStore.getState().selected).toBeNull();
  });

  it('draws no marker without a chosen sighting', async () => {
    serveMap();
    render(<MapView />);
    const map = screen.getByRole('region', { name: 'Map' });
    await within(map).findByTestId('robot');
    expect(within(map).queryByTestId('history-marker')).toBeNull();
    expect(within(map).queryByRole('button', { name: 'Clear history marker' })).toBeNull();
  });

  it('names but does not draw a pose recorded on another map', async () => {
    serveMap();
    useHistoryStore.setState({ selected: { ...parcel, pose: { ...parcel.pose!, map: 'warehouse' } } });
    render(<MapView />);
    const map = screen.getByRole('region', { name: 'Map' });
    await waitFor(() => expect(map).toHaveTextContent('yellow package was seen on map warehouse, not this one'));
    expect(within(map).queryByTestId('history-marker')).toBeNull();
  });
});

describe('map: the robot\'s own map', () => {
  it('names places as people do and a click fills "Go to" with that name', async () => {
    serveMap();
    render(<MapView />);
    const map = screen.getByRole('region', { name: 'Map' });
    const kitchen = await within(map).findByRole('button', { name: 'Go to Kitchen' });
    expect(map).not.toHaveTextContent('desk_alice');
    expect(within(map).queryByRole('button', { name: 'Go to kitchen' })).toBeNull();
    await userEvent.click(kitchen);
    expect(useChatStore.getState().draft).toBe('Go to Kitchen');
    await waitFor(() => expect(map).toHaveTextContent('At Charging dock'));
  });

  it('draws the floor plan, the way the robot saw blocked and the plan it follows', async () => {
    serveMap(DRIVING, FLOOR);
    render(<MapView />);
    const map = screen.getByRole('region', { name: 'Map' });
    await within(map).findByTestId('floor-plan');
    expect(within(map).getAllByRole('img', { name: /Blocked/ })).toHaveLength(1);
    const plan = await within(map).findByTestId('plan');
    expect(plan).toHaveAttribute('data-points', '3');
    expect(map).toHaveTextContent('Driving to Mailroom');
    expect(within(map).getByTestId('robot')).toHaveAccessibleName('Robot at 2.0, 1.0 driving to Mailroom');
  });

  it('shows no plan while the robot stands', async () => {
    serveMap(POSE, FLOOR);
    render(<MapView />);
    const map = screen.getByRole('region', { name: 'Map' });
    await within(map).findByTestId('floor-plan');
    expect(within(map).queryByTestId('plan')).toBeNull();
  });
});

describe('map: a robot base that is lost or came back', () => {
  const servePose = (pose: object) => serveMap(pose);

  it('dims the marker and says the position is not live while the base sends none', async () => {
    servePose({ ...POSE, at_location: null, x: 3, stale: true, pose_note: 'no pose from the robot base since it stopped answering 4 s ago' });
    render(<MapView />);
    const map = screen.getByRole('region', { name: 'Map' });
    const robot = await within(map).findByTestId('robot');
    expect(robot).toHaveAttribute('data-stale', 'true');
    expect(robot).toHaveAccessibleName('Robot last seen 3.0, 0.0');
    expect(await within(map).findByRole('status')).toHaveTextContent(
      'Position not live: no pose from the robot base since it stopped answering 4 s ago',
    );
  });

  it('says the marker jumped when the base came back elsewhere', async () => {
    servePose({
      ...POSE,
      stale: false,
      pose_note: 'the robot base came back 9.5 m from where it was last seen, 3 s ago',
      relocated: { from: { x: 9, y: -3 }, to: { x: 0, y: 0 }, distance_m: 9.5 },
    });
    render(<MapView />);
    const map = screen.getByRole('region', { name: 'Map' });
    expect(await within(map).findByRole('status')).toHaveTextContent('Position jumped: the robot base came back 9.5 m');
    expect(within(map).getByTestId('robot')).not.toHaveAttribute('data-stale');
  });
});
