import { render, screen } from '@testing-library/react';
import { afterEach, describe, expect, it, vi } from 'vitest';
import { HoldingChip } from './HoldingChip';

afterEach(() => vi.unstubAllGlobals());

function answer(status: number, body: unknown) {
  vi.stubGlobal(
    'fetch',
    vi.fn(async () => new Response(JSON.stringify(body), { status })),
  );
}

describe('holding chip', () => {
  it('names what the gripper holds, as the arm reported it', async () => {
    answer(200, { known: true, holding: true, label: 'yellow package', busy: false, action: null });
    render(<HoldingChip />);
    const chip = await screen.findByLabelText('Holding yellow package');
    expect(chip).toHaveAttribute('data-holding', 'yellow package');
    expect(chip).toHaveTextContent('Holding: yellow package');
  });

  it('says the gripper is empty and what the arm is doing', async () => {
    answer(200, { known: true, holding: false, label: null, busy: true, action: 'pick' });
    render(<HoldingChip />);
    const chip = await screen.findByLabelText('Gripper empty');
    expect(chip).toHaveAttribute('data-holding', '');
    expect(chip).toHaveTextContent('picking up');
  });

  it('does not guess before the robot reported', async () => {
    answer(200, { known: false, holding: null, label: null });
    render(<HoldingChip />);
    expect(await screen.findByLabelText('Gripper unknown')).toBeInTheDocument();
  });

  it('says when no arm is connected', async () => {
    answer(503, { error: 'manipulation_unavailable', detail: 'not connected' });
    render(<HoldingChip />);
    expect(await screen.findByText('not connected')).toBeInTheDocument();
    expect(screen.getByTestId('holding')).toHaveAttribute('data-holding', '');
  });
});
